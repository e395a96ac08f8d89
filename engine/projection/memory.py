"""What `projection` keeps between iterations (`ProjectionMemory`), and its JSON."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from itertools import chain
from typing import Any, ClassVar, Self

from engine.errors import EngineError
from engine.stepping.memory_fields import Fields, jsonable


@dataclass(frozen=True)
class Iterate:
    """The iterate r: states x (steps + 1 rows of n) and inputs u (steps + 1 rows of m);
    ``source``: the trajectory (`engine.projection.lq.Trajectory`) it was made from, never
    compared nor stored, so the next step takes its arrays back without converting."""

    x: tuple[tuple[float, ...], ...]
    u: tuple[tuple[float, ...], ...]
    source: object = field(default=None, compare=False, repr=False)


@dataclass(frozen=True)
class ProjectionMemory:
    """The iterate r_i, the product of the lambdas applied since the last reset, the last
    distances between the sets (the stall test), and whether lambda is held at 1 (``plain``:
    the sets were found disjoint)."""

    r: Iterate
    product: float
    distances: tuple[float, ...]
    plain: bool = False
    PLAIN_JSON: ClassVar[bool] = True  # `to_json` gives plain JSON (tests/engine/test_memory.py checks it)

    def to_json(self) -> dict:
        """Plain JSON types."""
        return {
            "r": {"x": _rows_json(self.r.x), "u": _rows_json(self.r.u)},
            **jsonable({"product": self.product, "distances": self.distances, "plain": self.plain}),
        }

    @classmethod
    def from_json(cls, data: Any) -> Self:
        """Read back `to_json`'s data; malformed data raises `EngineError` naming the field.
        ``plain`` may be missing (sessions saved before it was always written)."""
        fields = Fields(data, "projection memory")
        r = fields.object("r")
        x = _matrix(r, "x")
        u = _matrix(r, "u", len(x))
        product = fields.number("product")
        if not product > 0:
            raise EngineError(f"projection memory.product: expected a number > 0, got {product!r}")
        plain = False if "plain" not in fields.data else fields.boolean("plain")
        return cls(Iterate(x, u), product, fields.numbers("distances"), plain)


# The iterate has (steps + 1) x (n + m) entries and every step stores (and the guard reads back) the
# memory: the common case, rows of finite floats, is written and read without a call per entry.


def _finite_floats(rows: Iterable) -> bool:
    """Whether every entry of the rows is a finite float."""
    flat = list(chain.from_iterable(rows))
    return set(map(type, flat)) <= {float} and all(map(math.isfinite, flat))


def _rows_json(rows: tuple[tuple[float, ...], ...]) -> list:
    """`jsonable` of a matrix: the same lists, made directly when every entry is a finite float."""
    if set(map(type, rows)) <= {tuple} and _finite_floats(rows):
        return list(map(list, rows))
    return jsonable(rows)


def _matrix(fields: Fields, name: str, rows: int | None = None) -> tuple[tuple[float, ...], ...]:
    """`Fields.matrix` (finite entries; the same tuples), which reads and names what is wrong
    unless every row is a list of finite floats, all of one length."""
    value = fields.data.get(name)
    if (
        type(value) is list
        and (rows is None or len(value) == rows)
        and set(map(type, value)) <= {list}
        and len(set(map(len, value))) <= 1
        and _finite_floats(value)
    ):
        return tuple(map(tuple, value))
    return fields.matrix(name, rows)

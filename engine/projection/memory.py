"""What `projection` keeps between iterations (`ProjectionMemory`), and its JSON."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Self

from ..errors import EngineError
from ..memory import Fields, jsonable


@dataclass(frozen=True)
class Iterate:
    """The iterate r: states x (steps + 1 rows of n) and inputs u (steps + 1 rows of m)."""

    x: tuple[tuple[float, ...], ...]
    u: tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class ProjectionMemory:
    """The iterate r_i, the product of the lambdas applied since the last reset, the last
    distances between the sets (the stall test), and whether lambda is held at 1 (``plain``:
    the sets were found disjoint)."""

    r: Iterate
    product: float
    distances: tuple[float, ...]
    plain: bool = False

    def to_json(self) -> dict:
        """Plain JSON types."""
        return jsonable({"r": {"x": self.r.x, "u": self.r.u}, "product": self.product,
                         "distances": self.distances, "plain": self.plain})

    @classmethod
    def from_json(cls, data: Any) -> Self:
        """Read back `to_json`'s data; malformed data raises `EngineError` naming the field.
        ``plain`` may be missing (sessions saved before it was always written)."""
        fields = Fields(data, "projection memory")
        r = fields.object("r")
        x = r.matrix("x")
        u = r.matrix("u", len(x))
        product = fields.number("product")
        if not product > 0:
            raise EngineError(f"projection memory.product: expected a number > 0, got {product!r}")
        plain = False if "plain" not in fields.data else fields.boolean("plain")
        return cls(Iterate(x, u), product, fields.numbers("distances"), plain)

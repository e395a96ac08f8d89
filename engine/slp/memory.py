"""What `slp` keeps between minor-loop trials (`SlpMemory`), and its JSON."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Self

from engine.errors import EngineError
from engine.stepping.memory_fields import Fields, jsonable


@dataclass(frozen=True)
class SlpPoint:
    """A design point with its measure values and frequencies (NaN: absent), met-measure
    counter, figure of merit, and closed-loop stability."""

    x: tuple[float, ...]
    values: tuple[float, ...]
    frequencies: tuple[float, ...]
    counter: int
    merit: float
    stable: bool

    def to_json(self) -> dict:
        """Plain JSON types."""
        return jsonable(
            {
                "x": self.x,
                "values": self.values,
                "frequencies": self.frequencies,
                "counter": self.counter,
                "merit": self.merit,
                "stable": self.stable,
            }
        )

    @classmethod
    def from_json(cls, fields: Fields, size: int) -> Self:
        """Read back `to_json`'s data (``size`` free variables)."""
        values = fields.numbers("values", finite=False)
        return cls(
            fields.numbers("x", size),
            values,
            fields.numbers("frequencies", len(values), finite=False),
            fields.integer("counter"),
            fields.number("merit", finite=False),
            fields.boolean("stable"),
        )


@dataclass(frozen=True)
class SlpMemory:
    """The major and minor iteration numbers, the linearization point x0 and its point
    (``base``), the best point so far, the partials at x0 (None: not yet computed) and
    how each row's were found, the step size P of the next trial, the best P and the
    failed one (None: none yet) that bracket it, and the counts of evaluations and LPs."""

    major: int
    minor: int
    x0: tuple[float, ...]
    base: SlpPoint
    best: SlpPoint
    partials: tuple[tuple[float, ...], ...] | None
    partial_methods: tuple[str, ...]
    P: float
    P_best: float
    P_failed: float | None
    evaluations: int
    lps: int
    capped: bool = False  # the LP's objective leaves out rows past their desired value (`Slp._end_major`)

    def to_json(self) -> dict:
        """Plain JSON types (``capped`` only when set: a memory of the report's objective reads as before)."""
        return jsonable(
            {
                **({"capped": True} if self.capped else {}),
                "major": self.major,
                "minor": self.minor,
                "x0": self.x0,
                "base": self.base.to_json(),
                "best": self.best.to_json(),
                "partials": self.partials,
                "partial_methods": self.partial_methods,
                "P": self.P,
                "P_best": self.P_best,
                "P_failed": self.P_failed,
                "evaluations": self.evaluations,
                "lps": self.lps,
            }
        )

    @classmethod
    def from_json(cls, data: Any) -> Self:
        """Read back `to_json`'s data; malformed data raises `EngineError` naming the field."""
        fields = Fields(data, "slp memory")
        x0 = fields.numbers("x0")
        base = SlpPoint.from_json(fields.object("base"), len(x0))
        rows = len(base.values)
        partials = None if fields.get("partials") is None else fields.matrix("partials", rows, len(x0), finite=False)
        methods = tuple(_texts(fields, "partial_methods", rows))
        P = fields.number("P")
        if not P > 0:
            raise EngineError(f"slp memory.P: expected a step size > 0, got {P!r}")
        return cls(
            fields.integer("major", 1),
            fields.integer("minor"),
            x0,
            base,
            SlpPoint.from_json(fields.object("best"), len(x0)),
            partials,
            methods,
            P,
            fields.number("P_best"),
            fields.optional_number("P_failed"),
            fields.integer("evaluations"),
            fields.integer("lps"),
            fields.boolean("capped") if "capped" in fields.data else False,
        )


def _texts(fields: Fields, name: str, length: int) -> list[str]:
    """A list of strings: empty, or ``length`` of them."""
    items = fields.items(name)
    if items and len(items) != length:
        raise EngineError(f"{fields.where}.{name}: expected {length} items, got {len(items)}")
    if not all(isinstance(v, str) for v in items):
        raise EngineError(f"{fields.where}.{name}: expected strings")
    return items

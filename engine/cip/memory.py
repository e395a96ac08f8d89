"""What `cip` keeps between iterations (`CipMemory`), and its JSON."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Self

from ..errors import EngineError
from ..memory import Fields, jsonable, to_float
from ..problem import Point
from .constraints import KIND, Constraint

KINDS = tuple(sorted(set(KIND.values())))


@dataclass(frozen=True)
class CipBest:
    """The best coefficients so far (the listing's IBEST): the largest smallest stability margin."""

    iteration: int
    x: tuple[float, ...]
    smallest: float | None


@dataclass(frozen=True)
class CipMemory:
    """The margins at the current coefficients, the windings of 1 + GH per condition
    (the stability guard), the step size h, the unmet count at the start, the best point."""

    constraints: tuple[Constraint, ...]
    windings: tuple[float, ...]
    step: float
    unmet_start: int
    best: CipBest

    def to_json(self) -> dict:
        """Plain JSON types."""
        return jsonable({"constraints": [c.to_json() for c in self.constraints], "windings": self.windings,
                         "step": self.step, "unmet_start": self.unmet_start,
                         "best": {"iteration": self.best.iteration, "x": self.best.x,
                                  "smallest": self.best.smallest}})

    @classmethod
    def from_json(cls, data: Any) -> Self:
        """Read back `to_json`'s data; malformed data raises `EngineError` naming the field."""
        fields = Fields(data, "cip memory")
        best = fields.object("best")
        step = fields.number("step")
        if not step > 0:
            raise EngineError(f"cip memory.step: expected a step size > 0, got {step!r}")
        return cls(tuple(constraint_from(c) for c in fields.objects("constraints")), fields.numbers("windings"),
                   step, fields.integer("unmet_start"),
                   CipBest(best.integer("iteration"), best.numbers("x"), best.optional_number("smallest", False)))


def constraint_from(fields: Fields) -> Constraint:
    """A `Constraint` from its JSON (`Constraint.to_json`), every field checked."""
    kind = fields.text("kind")
    if kind not in KINDS:
        raise EngineError(f"{fields.where}.kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    gh = fields.numbers("gh", 2, finite=False)
    return Constraint(
        family=fields.text("family"), kind=kind, measure=fields.text("measure"),
        condition=fields.integer("condition"), frequency=fields.number("frequency", False),
        value=fields.number("value", False), desired=fields.number("desired"),
        shown=fields.number("shown", False), shown_desired=fields.number("shown_desired", False),
        weight=fields.number("weight"), method=fields.text("method"), gh=complex(*gh),
        points=tuple(_point(p, f"{fields.where}.points[{i}]") for i, p in enumerate(fields.items("points"))))


def _point(data: Any, where: str) -> Point:
    """A push/pull point: [real, imaginary, mode]."""
    if not (isinstance(data, list) and len(data) == 3 and data[2] in ("push", "pull")):
        raise EngineError(f"{where}: expected [real, imaginary, 'push' or 'pull'], got {data!r}")
    return Point(complex(to_float(data[0], f"{where}[0]"), to_float(data[1], f"{where}[1]")), data[2])

"""What `cip` keeps between iterations (`CipMemory`), and its JSON."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Self

from engine.cip.requirements import KIND, Requirement
from engine.design.problem import Point
from engine.errors import EngineError
from engine.stepping.memory_fields import Fields, jsonable, to_float

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

    requirements: tuple[Requirement, ...]
    windings: tuple[float, ...]
    step: float
    unmet_start: int
    best: CipBest
    PLAIN_JSON: ClassVar[bool] = True  # `to_json` gives plain JSON (tests/engine/test_memory.py checks it)

    def to_json(self) -> dict:
        """Plain JSON types (`jsonable`'s, built directly: every step stores its memory)."""
        return {
            "requirements": [_requirement_json(c.to_json()) for c in self.requirements],
            "windings": [_plain(w) for w in self.windings],
            "step": _plain(self.step),
            "unmet_start": _plain(self.unmet_start),
            "best": {
                "iteration": _plain(self.best.iteration),
                "x": [_plain(v) for v in self.best.x],
                "smallest": _plain(self.best.smallest),
            },
        }

    @classmethod
    def from_json(cls, data: Any) -> Self:
        """Read back `to_json`'s data; malformed data raises `EngineError` naming the field."""
        fields = Fields(data, "cip memory")
        best = fields.object("best")
        step = fields.number("step")
        if not step > 0:
            raise EngineError(f"cip memory.step: expected a step size > 0, got {step!r}")
        return cls(
            tuple(_quick_requirement(c.data) or requirement_from(c) for c in fields.objects("requirements")),
            fields.numbers("windings"),
            step,
            fields.integer("unmet_start"),
            CipBest(best.integer("iteration"), best.numbers("x"), best.optional_number("smallest", False)),
        )


def _plain(value: Any) -> Any:
    """`jsonable` of one value, without its dispatch for the common finite float, int and text."""
    kind = type(value)
    if kind is float:
        return value if math.isfinite(value) else repr(value)
    return value if kind is int or kind is str else jsonable(value)


def _requirement_json(data: dict) -> dict:
    """`jsonable` of `Requirement.to_json`'s dict (its lists: the points and gh)."""
    return {
        k: [[_plain(v) for v in p] for p in value]
        if k == "points"
        else [_plain(v) for v in value]
        if k == "gh"
        else _plain(value)
        for k, value in data.items()
    }


TEXTS = ("family", "kind", "measure", "method")
NUMBERS = {
    "frequency": False,
    "value": False,
    "desired": True,
    "shown": False,
    "shown_desired": False,
    "weight": True,
}  # field: must be finite


def _quick_requirement(data: Any) -> Requirement | None:
    """The requirement when every field is of its plain type (texts, a condition
    number, floats finite where required, points of finite floats); None
    otherwise, for `requirement_from` to read or to name what is wrong."""
    try:
        texts = [data[k] for k in TEXTS]
        numbers = [data[k] for k in NUMBERS]
        condition, gh, points = data["condition"], data["gh"], data["points"]
        if not (
            all(type(t) is str for t in texts)
            and texts[1] in KINDS
            and type(condition) is int
            and condition >= 0
            and type(gh) is list
            and len(gh) == 2
            and type(points) is list
            and all(
                type(v) is float and (math.isfinite(v) or not finite)
                for v, finite in zip(numbers + gh, list(NUMBERS.values()) + [False, False])
            )
            and all(
                type(p) is list
                and len(p) == 3
                and p[2] in ("push", "pull")
                and type(p[0]) is float
                and type(p[1]) is float
                and math.isfinite(p[0])
                and math.isfinite(p[1])
                for p in points
            )
        ):
            return None
    except (KeyError, TypeError):
        return None
    family, kind, measure, method = texts
    frequency, value, desired, shown, shown_desired, weight = numbers
    return Requirement(
        family=family,
        kind=kind,
        measure=measure,
        condition=condition,
        frequency=frequency,
        value=value,
        desired=desired,
        shown=shown,
        shown_desired=shown_desired,
        weight=weight,
        method=method,
        gh=complex(*gh),
        points=tuple(Point(complex(p[0], p[1]), p[2]) for p in points),
    )


def requirement_from(fields: Fields) -> Requirement:
    """A `Requirement` from its JSON (`Requirement.to_json`), every field checked."""
    kind = fields.text("kind")
    if kind not in KINDS:
        raise EngineError(f"{fields.where}.kind: expected one of {', '.join(KINDS)}, got {kind!r}")
    gh = fields.numbers("gh", 2, finite=False)
    return Requirement(
        family=fields.text("family"),
        kind=kind,
        measure=fields.text("measure"),
        condition=fields.integer("condition"),
        frequency=fields.number("frequency", False),
        value=fields.number("value", False),
        desired=fields.number("desired"),
        shown=fields.number("shown", False),
        shown_desired=fields.number("shown_desired", False),
        weight=fields.number("weight"),
        method=fields.text("method"),
        gh=complex(*gh),
        points=tuple(_point(p, f"{fields.where}.points[{i}]") for i, p in enumerate(fields.items("points"))),
    )


def _point(data: Any, where: str) -> Point:
    """A push/pull point: [real, imaginary, mode]."""
    if not (isinstance(data, list) and len(data) == 3 and data[2] in ("push", "pull")):
        raise EngineError(f"{where}: expected [real, imaginary, 'push' or 'pull'], got {data!r}")
    return Point(complex(to_float(data[0], f"{where}[0]"), to_float(data[1], f"{where}[1]")), data[2])

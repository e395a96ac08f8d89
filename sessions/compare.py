"""`loopcraft compare`: two designs' measures side by side.

A design is a session at an iteration.  Its measures are the generic tableau
of `engine.design.tableau` at that iteration's parameters (every target in every
condition, with desired values and met/unmet); a session whose targets the
tableau cannot evaluate (slp's modal peaks, time responses) is compared on
its records' own measures instead (iteration 0: the algorithm's initial
record), and the result says so.  Rows are matched by condition, kind and
name (G1, P1, wc, ...); the difference is B - A.

Two sessions need not pose the same problem: when their plants, targets,
constraints, grids or objectives differ (`problem_differences`: the JSON paths
where they do, parameter values aside, which are the designs), the comparison
says so, and where, before it says which design meets more of its targets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from engine.design.tableau import tableau
from engine.errors import EngineError, shortened
from engine.stepping.driver import first_record
from engine.stepping.memory_fields import finite_or_none
from engine.stepping.protocol import MeasureRow
from sessions.errors import SessionError
from sessions.export.design_model import iteration_parameters
from sessions.format.json_diff import changes, location
from sessions.lifecycle import registration, stepper
from sessions.store import Session


@dataclass(frozen=True)
class Side:
    """One design: where it comes from and its measures."""

    source: str
    iteration: int
    parameters: dict
    rows: tuple[MeasureRow, ...]
    how: str  # "tableau" or "records"

    @property
    def met(self) -> int:
        return sum(bool(r.satisfied) for r in self.rows)


@dataclass(frozen=True)
class Comparison:
    """Two designs and their matched rows: (key, A's row or None, B's row or None)."""

    a: Side
    b: Side
    rows: tuple[tuple[tuple[str, str, str], MeasureRow | None, MeasureRow | None], ...]
    notes: tuple[str, ...] = field(default=())
    differences: tuple[str, ...] = field(default=())  # where the two problems differ (empty: the same problem)

    @property
    def better(self) -> str:
        """ "a" or "b": the one meeting more targets; "tie" when they meet as many."""
        return "a" if self.a.met > self.b.met else "b" if self.b.met > self.a.met else "tie"


def side(session: Session, iteration: int | None, source: str) -> Side:
    """The measures of ``session`` at ``iteration`` (default: its last)."""
    k, named = iteration_parameters(session, iteration)
    problem = session.problem
    parameters = problem.named() if named is None else dict(named)
    try:
        rows = tableau(problem.with_vector(problem.vector_from(parameters)), require_stable=True)
        return Side(source, k, parameters, tuple(rows), "tableau")
    except EngineError as exc:
        if "the tableau evaluates" not in str(exc):
            raise SessionError(f"{source}: iteration {k}: {exc}") from None
    return Side(source, k, parameters, tuple(_record_rows(session, k, source)), "records")


def _record_rows(session: Session, k: int, source: str) -> list[MeasureRow]:
    if k:
        return list(session.records[k - 1].measures)
    try:
        record = first_record(registration(session).presenter, stepper(session))
    except EngineError as exc:
        raise SessionError(f"{source}: iteration 0: {exc}") from None
    if record is None:
        raise SessionError(f"{source}: iteration 0: the loop cannot be evaluated at the start")
    return list(record.measures)


SHOWN_DIFFERENCES = 5  # the first paths where two problems differ that are listed (then a count)


def problem_differences(a: Session, b: Session) -> tuple[str, ...]:
    """Where the two sessions' problems differ, as JSON paths with both values (the parameters'
    values aside: they are the designs compared); empty when they pose the same problem."""
    found = [
        f"{location(('problem', *c.path))}: {_brief(c.old)} in A, {_brief(c.new)} in B"
        for c in changes(_problem(a), _problem(b), absent=None)
    ]
    if len(found) > SHOWN_DIFFERENCES:
        found = found[:SHOWN_DIFFERENCES] + [f"and {len(found) - SHOWN_DIFFERENCES} more"]
    return tuple(found)


def _problem(session: Session) -> dict:
    data = session.model.problem.model_dump(mode="json")
    for parameter in data.get("parameters", []):
        parameter.pop("value", None)
    return data


def _brief(value: object) -> str:
    text = "absent" if value is None else repr(value) if isinstance(value, str) else str(value)
    return shortened(text, 60, "…")


def compare(a: Side, b: Side, differences: tuple[str, ...] = ()) -> Comparison:
    """Match the two sides' rows by (condition, kind, name), in A's order then B's extra ones;
    ``differences``: where the two problems differ (`problem_differences`)."""

    def keyed(rows) -> dict:
        return {(r.condition, r.kind, r.name): r for r in rows}

    left, right = keyed(a.rows), keyed(b.rows)
    keys = list(left) + [k for k in right if k not in left]
    notes = []
    if a.how != "tableau" or b.how != "tableau":
        notes.append("the generic tableau cannot evaluate every target: the records' own measures are compared")
    missing = [k for k in keys if k not in left or k not in right]
    if missing:
        notes.append(f"{len(missing)} measure(s) found in one design only (a crossing that the other lacks)")
    return Comparison(a, b, tuple((k, left.get(k), right.get(k)) for k in keys), tuple(notes), differences)


def difference(ra: MeasureRow | None, rb: MeasureRow | None) -> float | None:
    """B - A of a matched row (None when either is missing or not finite)."""
    if ra is None or rb is None or not (math.isfinite(ra.value) and math.isfinite(rb.value)):
        return None
    return rb.value - ra.value


def _row_json(r: MeasureRow | None) -> dict | None:
    if r is None:
        return None
    return {"value": finite_or_none(r.value), "frequency": finite_or_none(r.frequency), "satisfied": bool(r.satisfied)}


def comparison_json(c: Comparison) -> dict:
    """The comparison as JSON data (`loopcraft compare --json`)."""

    def side_json(s: Side) -> dict:
        return {
            "source": s.source,
            "iteration": s.iteration,
            "parameters": s.parameters,
            "met": s.met,
            "measures": len(s.rows),
            "how": s.how,
        }

    rows = []
    for (condition, kind, name), ra, rb in c.rows:
        desired = (ra or rb).desired
        rows.append(
            {
                "condition": condition,
                "kind": kind,
                "name": name,
                "target": finite_or_none(desired),  # the JSON key other programs read
                "desired": finite_or_none(desired),  # A's (B's when A lacks the row)
                "desired_a": None if ra is None else finite_or_none(ra.desired),
                "desired_b": None if rb is None else finite_or_none(rb.desired),
                "a": _row_json(ra),
                "b": _row_json(rb),
                "difference": difference(ra, rb),
            }
        )
    return {
        "a": side_json(c.a),
        "b": side_json(c.b),
        "rows": rows,
        "better": c.better,
        "notes": list(c.notes),
        "same_problem": not c.differences,
        "differences": list(c.differences),
    }


def comparison_text(c: Comparison) -> str:
    """A side-by-side table, the parameters, and which design meets more targets."""

    def cell(r: MeasureRow | None) -> str:
        return f"{'-':>12} {'':3}" if r is None else f"{r.value:>12.6g} {'yes' if r.satisfied else 'NO':3}"

    lines = [
        f"A: {c.a.source}, iteration {c.a.iteration}",
        f"B: {c.b.source}, iteration {c.b.iteration}",
        "",
        f"{'condition':<12} {'kind':<20} {'name':<5} {'desired':>15} {'A':>12} met {'B':>12} met {'B - A':>12}",
    ]
    for (condition, kind, name), ra, rb in c.rows:
        d = difference(ra, rb)
        lines.append(
            f"{condition:<12} {kind:<20} {name:<5} {_desired(ra, rb):>15} "
            f"{cell(ra)} {cell(rb)} {'' if d is None else f'{d:.6g}':>12}"
        )
    lines += ["", f"{'parameter':<12} {'A':>14} {'B':>14}"]
    for name in dict.fromkeys(list(c.a.parameters) + list(c.b.parameters)):
        lines.append(f"{name:<12} {_shown(c.a.parameters.get(name)):>14} {_shown(c.b.parameters.get(name)):>14}")
    lines.append("")
    if c.differences:
        lines.append("the problems differ (each design is judged on its own targets):")
        lines += [f"  {d}" for d in c.differences]
    verdict = {"a": "A meets more targets", "b": "B meets more targets", "tie": "they meet as many targets"}
    lines.append(f"{verdict[c.better]}: A {c.a.met} of {len(c.a.rows)}, B {c.b.met} of {len(c.b.rows)}")
    lines += [f"note: {n}" for n in c.notes]
    return "\n".join(lines)


def _desired(ra: MeasureRow | None, rb: MeasureRow | None) -> str:
    """The desired value, or A's and B's ("8 / 6", "A: 8", "B: 6") where the two differ."""
    a, b = (None if r is None else r.desired for r in (ra, rb))
    text = {x: "" if x is None else f"{x:.6g}" for x in (a, b)}
    if ra is None or rb is None or text[a] == text[b]:
        return text[a if ra is not None else b]
    return f"{text[a] or '-'} / {text[b] or '-'}"


def _shown(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, list):
        return "/".join(f"{v:.4g}" for v in value)
    return f"{value:.6g}"

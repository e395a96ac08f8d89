"""The stages before a session's current run: earlier runs, each with the parameters it
started from, its algorithm and its records, and the hand moves between them (issue 38,
section 3).  A hand move makes the design on screen a new start, so the algorithm begins
afresh from it; the run it came from is kept here rather than dropped, and `replay`
reproduces every earlier run's iterations on its own start and checks that the stages
lead from one to the next.  An edit of anything but parameter values (a target, a
block, a bound) makes the earlier runs unreproducible on the problem now: they are
dropped with the current run's."""

from __future__ import annotations

import math
from typing import Any

from engine.stepping.protocol import StepRecord
from sessions.format.schema import HandChangeModel, HandStageModel, ProblemModel, RunStageModel
from sessions.store import Session

MATCH = 1e-12  # relative: a stage's end and the next one's beginning are the same values


def start_values(session: Session) -> dict[str, Any]:
    """The session's start: each parameter's value (a list for a per-condition one)."""
    return {p.name: _copied(p.value) for p in session.model.problem.parameters}


def keep_run(session: Session) -> None:
    """The current run (its start, its algorithm and its records up to the current
    iteration) becomes an earlier stage: called before its design becomes the start."""
    model = session.model
    k = model.current_iteration
    if k == 0:
        return
    model.earlier.append(
        RunStageModel(
            kind="run",
            parameters=[p.model_copy(deep=True) for p in model.problem.parameters],
            algorithm=model.algorithm.model_copy(deep=True),
            records=list(model.records[:k]),
        )
    )


def note_edit(session: Session, before: ProblemModel) -> None:
    """After an edit of the problem from ``before``: parameter values alone changed is a
    hand move (a hand stage, joined to a hand stage just before it); anything else
    drops the earlier stages."""
    after = session.model.problem
    if _structure(before) != _structure(after):
        session.model.earlier.clear()
        return
    old = {p.name: p.value for p in before.parameters}
    changes = [
        HandChangeModel(name=p.name, before=_copied(old[p.name]), after=_copied(p.value))
        for p in after.parameters
        if old[p.name] != p.value
    ]
    earlier = session.model.earlier
    if earlier and earlier[-1].kind == "hand":
        changes = _joined(earlier.pop().changes, changes)
    if changes:
        earlier.append(HandStageModel(kind="hand", changes=changes))


def hand_text(stage: HandStageModel) -> str:
    """'T1: 1 -> 1.34; K: 7.14 -> 5.66'."""
    return "; ".join(f"{c.name}: {value_text(c.before)} -> {value_text(c.after)}" for c in stage.changes)


def earlier_lines(session: Session) -> list[str]:
    """The earlier stages, one line each, then the current run's beginning:
    'run 1: cip, iterations 1-12 (converged)', 'hand: T1: 1 -> 1.34', 'run 2 (the current
    one) starts from there, the algorithm's memory afresh'."""
    lines, runs = [], 0
    for stage in session.model.earlier:
        if stage.kind == "hand":
            lines.append(f"hand: {hand_text(stage)}")
            continue
        runs += 1
        n = len(stage.records)
        status = StepRecord.from_json(stage.records[-1]).status.value if n else "no iterations"
        span = "iteration 1" if n == 1 else f"iterations 1-{n}"
        lines.append(f"run {runs}: {stage.algorithm.name}, {span} ({status})")
    if lines:
        lines.append(f"run {runs + 1} (below) starts from there, the algorithm's memory afresh")
    return lines


def chain_break(session: Session) -> str | None:
    """Where the stages do not lead from one to the next (a run's last design to the hand
    move's values before, a hand move's values after to the next run's start, the last
    stage's end to the session's start); None when they all do."""
    ends = [(f"earlier stage {k}", *_ends(stage)) for k, stage in enumerate(session.model.earlier, start=1)]
    ends.append(("the current run", start_values(session), None))
    for (name, _, end), (next_name, begin, _) in zip(ends, ends[1:]):
        for key, value in end.items():
            if key in begin and not _same(value, begin[key]):
                return f"{name} ends with {key} = {value_text(value)}, {next_name} begins with {value_text(begin[key])}"
    return None


def _ends(stage) -> tuple[dict[str, Any], dict[str, Any]]:
    """A stage's parameter values at its beginning and at its end."""
    if stage.kind == "hand":
        return {c.name: c.before for c in stage.changes}, {c.name: c.after for c in stage.changes}
    begin = {p.name: p.value for p in stage.parameters}
    end = dict(StepRecord.from_json(stage.records[-1]).parameters) if stage.records else begin
    return begin, end


def _structure(problem: ProblemModel) -> dict:
    """The problem without its parameters' values: what a hand move leaves as it was."""
    data = problem.model_dump()
    data["parameters"] = [{**p, "value": None} for p in data["parameters"]]
    return data


def _joined(first: list[HandChangeModel], then: list[HandChangeModel]) -> list[HandChangeModel]:
    """Two hand moves in a row as one: each parameter's first value before and last after."""
    merged = {c.name: c for c in first}
    for c in then:
        merged[c.name] = (
            HandChangeModel(name=c.name, before=merged[c.name].before, after=c.after) if c.name in merged else c
        )
    return [c for c in merged.values() if c.before != c.after]


def _same(a: Any, b: Any) -> bool:
    a, b = (list(a) if isinstance(a, (list, tuple)) else [a]), (list(b) if isinstance(b, (list, tuple)) else [b])
    return len(a) == len(b) and all(math.isclose(x, y, rel_tol=MATCH, abs_tol=0.0) for x, y in zip(a, b))


def _copied(value: Any) -> Any:
    return list(value) if isinstance(value, list) else value


def value_text(value: Any) -> str:
    """A parameter's value as the status line and the history write it: '1.34', or
    '[0.5, 0.6]' for one per condition."""
    return "[" + ", ".join(f"{v:.6g}" for v in value) + "]" if isinstance(value, (list, tuple)) else f"{value:.6g}"

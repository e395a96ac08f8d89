"""Run a session's algorithm, and replay a session to check its records."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass

from engine.algorithm import State, StepRecord, iterate
from engine.errors import EngineError

from .errors import SessionError
from .lifecycle import bound_algorithm, forget_records
from .store import AUTOSAVE_INTERVAL, Session, write_autosave

REPLAY_TOLERANCE = 1e-9


class Run(list):
    """The records a run made (a list of `StepRecord`); ``stopped`` is "time limit" when
    the wall-clock bound ended it early (`engine.algorithm.Iteration.stopped`), else None."""

    stopped: str | None = None


def run_session(session: Session, iterations: int | None = None, until_done: bool = False,
                progress: Callable[[StepRecord], None] | None = None, autosave: bool = True,
                time_limit: float | None = None) -> Run:
    """Step from the current iteration; records after it (an undone tail) are dropped.
    ``time_limit``: seconds of wall clock, checked between iterations (the run stops
    there, resumable, its records a prefix of the unlimited run's: it replays)."""
    algorithm, settings = bound_algorithm(session)
    model = session.model
    del model.records[model.current_iteration:]
    new = Run()
    try:
        state = algorithm.init(session.problem, settings)
        if model.current_iteration and model.state is not None:
            state = State.from_json(model.state, algorithm.memory_type)
        limit = iterations if iterations is not None else (10**9 if until_done else 1)
        steps = iterate(algorithm, session.problem, settings, max_iter=limit, state=state, time_limit=time_limit)
        for state, record in steps:
            model.records.append(record.to_json())
            model.state = state.to_json()
            model.current_iteration = len(model.records)
            new.append(record)
            if progress:
                progress(record)
            if autosave:
                write_autosave(session, at_most_every=AUTOSAVE_INTERVAL)
        new.stopped = steps.stopped
        if autosave and new:
            write_autosave(session)
    except EngineError as exc:
        raise SessionError(f"{model.algorithm.name}: {exc}") from None
    return new


def set_setting(session: Session, assignment: str) -> None:
    """Apply NAME=VALUE to the algorithm's settings (VALUE read as JSON, else as text)."""
    name, sep, text = assignment.partition("=")
    if not sep or not name.strip():
        raise SessionError(f"--set {assignment!r}: write NAME=VALUE")
    try:
        value = json.loads(text)
    except json.JSONDecodeError:
        value = text
    session.model.algorithm.settings[name.strip()] = value
    forget_records(session)


@dataclass(frozen=True)
class ReplayResult:
    ok: bool
    iterations: int
    message: str


def _close(a: float | None, b: float | None) -> bool:
    if a is None or b is None:
        return a is b
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= REPLAY_TOLERANCE * max(abs(a), abs(b), 1e-300) or a == b


def _first_difference(old: StepRecord, new: StepRecord) -> str | None:
    if old.status != new.status:
        return f"status {old.status.value!r} recorded, {new.status.value!r} now"
    for name, value in old.parameters.items():
        again = new.parameters.get(name)
        pairs = zip(value, again) if isinstance(value, list) and isinstance(again, list) else [(value, again)]
        if again is None or not all(_close(a, b) for a, b in pairs):
            return f"parameter {name}: {value!r} recorded, {again!r} now"
    if len(old.measures) != len(new.measures):
        return f"{len(old.measures)} measures recorded, {len(new.measures)} now"
    for m, n in zip(old.measures, new.measures):
        if not (_close(m.value, n.value) and _close(m.frequency, n.frequency)):
            return f"measure {m.name} ({m.kind}, {m.condition}): {m.value!r} recorded, {n.value!r} now"
    if not _close(old.objective, new.objective):
        return f"objective: {old.objective!r} recorded, {new.objective!r} now"
    return None


def replay(session: Session) -> ReplayResult:
    """Re-run from the initial state; compare every record to 1e-9 relative."""
    algorithm, settings = bound_algorithm(session)
    recorded = session.records
    try:
        state = algorithm.init(session.problem, settings)
        for old in recorded:
            state, new = algorithm.step(state)
            difference = _first_difference(old, new)
            if difference:
                return ReplayResult(False, old.iteration, f"iteration {old.iteration} diverges: {difference}")
    except EngineError as exc:
        raise SessionError(f"replay: {exc}") from None
    return ReplayResult(True, len(recorded), f"all {len(recorded)} recorded iterations reproduce")

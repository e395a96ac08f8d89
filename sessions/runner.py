"""Run a session's algorithm, and replay a session to check its records."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from engine.algorithm import State, StepRecord, lookup, make_settings
from engine.errors import EngineError

from .build import build_problem
from .errors import SessionError
from .store import AUTOSAVE_INTERVAL, Session, write_autosave

REPLAY_TOLERANCE = 1e-9


def _algorithm(session: Session):
    name = session.model.algorithm.name
    try:
        registration = lookup(name)
        settings = make_settings(name, session.model.algorithm.settings)
    except (EngineError, TypeError) as exc:
        raise SessionError(f"algorithm: {exc}") from None
    return registration.factory(), settings


def run_session(session: Session, iterations: int | None = None, until_done: bool = False,
                progress: Callable[[StepRecord], None] | None = None, autosave: bool = True) -> list[StepRecord]:
    """Step from the current iteration; records after it (an undone tail) are dropped."""
    algorithm, settings = _algorithm(session)
    model = session.model
    del model.records[model.current_iteration:]
    try:
        state = algorithm.init(session.problem, settings)
        if model.current_iteration and model.state is not None:
            state = State.from_json(model.state)
        limit = iterations if iterations is not None else (10**9 if until_done else 1)
        new: list[StepRecord] = []
        while len(new) < limit and not state.status.finished:
            state, record = algorithm.step(state)
            model.records.append(record.to_json())
            model.state = state.to_json()
            model.current_iteration = len(model.records)
            new.append(record)
            if progress:
                progress(record)
            if autosave:
                write_autosave(session, at_most_every=AUTOSAVE_INTERVAL)
        if autosave and new:
            write_autosave(session)
    except EngineError as exc:
        raise SessionError(f"{model.algorithm.name}: {exc}") from None
    return new


def adopt_design(session: Session) -> None:
    """Make the current iteration's parameters the session's starting values and
    forget the records (to continue with other settings, e.g. slp's load-relief
    phase after its margin phase)."""
    model = session.model
    if model.current_iteration:
        adopt_parameters(session, StepRecord.from_json(model.records[model.current_iteration - 1]).parameters)


def adopt_parameters(session: Session, values: dict) -> None:
    """Set the session's parameter values (name -> value or list per condition),
    forget its records and rebuild its problem."""
    model = session.model
    for parameter in model.problem.parameters:
        if parameter.name in values:
            parameter.value = values[parameter.name]
    _forget_records(model)
    folder = session.path.parent if session.path else Path.cwd()
    session.problem = build_problem(model.problem, folder)


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
    _forget_records(session.model)


def _forget_records(model) -> None:
    """No iterations any more: the problem or the settings changed."""
    model.records.clear()
    model.current_iteration = 0
    model.state = None


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
    algorithm, settings = _algorithm(session)
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

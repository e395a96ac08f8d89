"""A session's lifecycle in one place: where it lives, its algorithm bound
to its settings, forgetting its records when the problem or the algorithm
changes, rebuilding its problem after an edit, adopting a design.

The workbench, the CLI and the sweeps all go through these, so "the records
are dropped" means the same everywhere (records, current iteration and the
saved state together)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.stepping.protocol import Stepper, StepRecord
from engine.stepping.registry import Registration, lookup, make_settings
from sessions.build import build_problem
from sessions.errors import SessionError
from sessions.format.save_file import real_path
from sessions.format.schema import AlgorithmModel
from sessions.hand_history import keep_run, note_edit
from sessions.store import Session
from sessions.target_use import JudgedAside, read_targets


def folder(session: Session) -> Path:
    """The folder a session's relative paths (CSV tables) are read from: the real
    file's (through a symlink), or the working folder for a session not yet saved."""
    return real_path(session.path).parent if session.path is not None else Path.cwd()


def registration(session: Session) -> Registration:
    """The session's algorithm as registered (a `SessionError` when unknown)."""
    try:
        return lookup(session.model.algorithm.name)
    except EngineError as exc:
        raise SessionError(f"algorithm: {exc}") from None


def stepper(session: Session) -> Stepper:
    """The session's algorithm bound to its problem and settings (a `SessionError` when the
    algorithm or its settings are unknown; the algorithm's own checks of the problem raise
    `EngineError`)."""
    return bind(session.model.algorithm, session.problem)[1]


def bind(model: AlgorithmModel, problem: Problem) -> tuple[Registration, Stepper]:
    """An algorithm section's registration and its stepper bound to ``problem``."""
    try:
        found = lookup(model.name)
        settings = make_settings(model.name, model.settings)
    except (EngineError, TypeError) as exc:
        raise SessionError(f"algorithm: {exc}") from None
    read, aside = read_targets(found, problem)
    bound = found.bind(read, settings)
    return found, bound if aside is None else JudgedAside(bound, aside)


def forget_records(session: Session) -> None:
    """No iterations any more: the problem, the settings or the algorithm changed."""
    model = session.model
    model.records.clear()
    model.current_iteration = 0
    model.state = None


def switch_algorithm(session: Session, name: str) -> None:
    """Another algorithm with its default settings; the records are dropped."""
    try:
        lookup(name)
    except EngineError as exc:
        raise SessionError(str(exc)) from None
    session.model.algorithm.name = name
    session.model.algorithm.settings = {}
    forget_records(session)


def rebuild(session: Session, start_checked: bool = True) -> None:
    """Build the engine problem again from the edited model; the records are dropped.
    A `SessionError` says why it does not build (the session is unchanged then);
    ``start_checked`` False leaves the constraints to the end of a change (`build_problem`)."""
    session.problem = build_problem(
        session.model.problem,
        folder(session),
        allow_outside_tables=session.allow_outside_tables or None,
        start_checked=start_checked,
    )
    forget_records(session)


def adopt_parameters(session: Session, values: Mapping[str, Any], jump: bool = True) -> list[str]:
    """Make a design (name -> value, or a list per condition) the session's start; a value
    outside its parameter's design bounds (a tolerance sample's) widens them to hold it:
    what was widened, one line each (also kept in the session's messages).  A ``jump``
    (a design from elsewhere, such as a sweep's) is noted in the earlier stages as a
    hand move would be (`hand_history.note_edit`)."""
    before = session.model.problem.model_copy(deep=True)
    widened = []
    for parameter in session.model.problem.parameters:
        if parameter.name in values:
            value = values[parameter.name]
            low, high, note = bounds_holding(parameter.name, parameter.min, parameter.max, value)
            parameter.min, parameter.max, parameter.value = low, high, value
            widened += [note] if note else []
    rebuild(session)
    if jump:
        note_edit(session, before)
    session.messages.extend(widened)
    return widened


def bounds_holding(name: str, low: float | None, high: float | None, value: Any) -> tuple:
    """(min, max) widened to hold ``value`` (a number or one per condition), and what was
    widened (None: nothing).  Design bounds limit the optimizer's search, not a value a
    tolerance study samples or a design adopted from it."""
    values = value if isinstance(value, list) else [value]
    new_low = low if low is None or min(values) >= low else min(values)
    new_high = high if high is None or max(values) <= high else max(values)
    if (new_low, new_high) == (low, high):
        return low, high, None
    return (
        new_low,
        new_high,
        f"{name}: design bounds [{low}, {high}] widened to [{new_low}, {new_high}] to hold {value}",
    )


def adopt_current(session: Session) -> None:
    """Start from the current iteration's parameters (to continue with other
    settings, e.g. slp's load-relief phase after its margin phase); the run that
    led there is kept as an earlier stage (`hand_history.keep_run`)."""
    k = session.model.current_iteration
    if k:
        keep_run(session)
        adopt_parameters(session, StepRecord.from_json(session.model.records[k - 1]).parameters, jump=False)


def named_error(name: str, exc: Exception) -> SessionError:
    """An engine failure as a `SessionError` that names the algorithm once."""
    text = str(exc)
    return SessionError(text if text.startswith(f"{name}: ") else f"{name}: {text}")

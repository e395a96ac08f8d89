"""Run a session's algorithm, and replay a session to check its records."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from engine.errors import EngineError
from engine.stepping.driver import iterate, resume
from engine.stepping.memory_fields import jsonable
from engine.stepping.protocol import State, StepRecord
from sessions.build import build_problem
from sessions.errors import SessionError, in_words
from sessions.format.json_diff import ABSENT, changes, location
from sessions.format.schema import SessionModel
from sessions.hand_history import chain_break
from sessions.lifecycle import folder, forget_records, named_error, stepper
from sessions.store import AUTOSAVE_INTERVAL, Session, write_autosave

REPLAY_TOLERANCE = 1e-9  # relative
REPLAY_FLOOR = 1e-12  # absolute: a recorded 0.0 against 1e-13 is numerical noise, not a divergence
NON_FINITE = ("inf", "-inf", "nan")


class Run(list):
    """The records a run made (a list of `StepRecord`); ``stopped`` is "time limit" when
    the wall-clock bound ended it early (`engine.stepping.protocol.Iteration.stopped`), else None."""

    stopped: str | None = None


def run_session(
    session: Session,
    iterations: int | None = None,
    until_done: bool = False,
    progress: Callable[[StepRecord], None] | None = None,
    autosave: bool = True,
    time_limit: float | None = None,
) -> Run:
    """Step from the current iteration; records after it (an undone tail) are dropped.
    ``time_limit``: seconds of wall clock, checked between iterations (the run stops
    there, resumable, its records a prefix of the unlimited run's: it replays)."""
    model = session.model
    del model.records[model.current_iteration :]
    new = Run()
    try:
        bound = stepper(session)
        snapshot = settings_snapshot(bound.settings)
        state = resume(bound, model.state, model.current_iteration)
        limit = iterations if iterations is not None else (10**9 if until_done else 1)
        steps = iterate(bound, max_iter=limit, state=state, time_limit=time_limit)
        for state, record in steps:
            model.records.append(record_json(record, snapshot))
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
        raise named_error(model.algorithm.name, exc) from None
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


def settings_snapshot(settings: Any) -> dict:
    """The algorithm's settings in full (defaults included) as JSON data, as a record keeps them."""
    values = dataclasses.asdict(settings) if dataclasses.is_dataclass(settings) else dict(vars(settings))
    return jsonable(values)


def record_json(record: StepRecord, settings: dict | None = None) -> dict:
    """A record as the session keeps it: its JSON, with the settings that made it
    (``settings``: a `settings_snapshot`) under the key "settings"."""
    data = record.to_json()
    if settings is not None:
        data["settings"] = settings
    return data


def difference(old: Any, new: Any, where: str = "") -> str | None:
    """Where two JSON values first differ, as "PATH: OLD recorded, NEW now" (None: they agree).
    Numbers agree within REPLAY_TOLERANCE relative or REPLAY_FLOOR absolute, NaN equals
    NaN; objects agree key by key, lists by length and then element by element."""
    first = next(changes(old, new, same=_same), None)
    if first is None:
        return None
    path, old, new = location((where, *first.path) if where else first.path), first.old, first.new
    if new is ABSENT:
        return f"{path}: {old!r} recorded, missing now"
    if old is ABSENT:
        return f"{path}: missing in the record, {new!r} now"
    old, new = _number(old), _number(new)
    if isinstance(old, list) and isinstance(new, list):
        return f"{path}: {len(old)} entries recorded, {len(new)} now"
    return f"{path}: {old!r} recorded, {new!r} now"


def _same(old: Any, new: Any) -> bool:
    """Two leaves agree: numbers within the replay's tolerance (NaN equals NaN, a number kept
    as text read as one), anything else of one type and equal."""
    old, new = _number(old), _number(new)
    return _close(old, new) if _is_number(old) and _is_number(new) else type(old) is type(new) and old == new


def _number(value: Any) -> Any:
    return float(value) if isinstance(value, str) and value in NON_FINITE else value


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _close(a: float, b: float) -> bool:
    if isinstance(a, int) and isinstance(b, int):
        return a == b
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= max(REPLAY_TOLERANCE * max(abs(a), abs(b)), REPLAY_FLOOR)


@dataclass(frozen=True)
class ReplayResult:
    """What `replay` found: ``ok`` (every record, the settings and the saved state
    reproduce), how many iterations were checked, and the message to print."""

    ok: bool
    iterations: int
    message: str


def replay(session: Session) -> ReplayResult:
    """Re-run from the initial state; compare every field of every record, the
    settings the records were made with, and the saved state (by `difference`).
    Earlier runs are replayed first, each on its own start, and the stages are checked
    to lead from one to the next (`hand_history`)."""
    model = session.model
    found, earlier = _earlier_difference(session)
    if found:
        return ReplayResult(False, 0, found)
    try:
        bound = stepper(session)
        snapshot = settings_snapshot(bound.settings)
        state = bound.init()
        if model.current_iteration == 0 and (found := _state_difference(model.state, state, 0)):
            return ReplayResult(False, 0, found)
        for k, old in enumerate(model.records, start=1):
            found = _settings_difference(k, old, snapshot) or _finished_early(k, state)
            if found:
                return ReplayResult(False, k, found)
            state, new = bound.step(state)
            found = _record_difference(k, old, record_json(new, snapshot if "settings" in old else None))
            if not found and k == model.current_iteration:
                found = _state_difference(model.state, state, k)
            if found:
                return ReplayResult(False, k, found)
    except SessionError:
        raise
    except EngineError as exc:
        raise SessionError(f"replay: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any failure of a step is an error of the replay (exit 2)
        raise SessionError(f"replay: {in_words(exc)}") from None
    return ReplayResult(True, len(model.records), _success(model) + earlier)


def _earlier_difference(session: Session) -> tuple[str | None, str]:
    """Replay every earlier run of a session on its own start (parameters and
    algorithm), then check the chain of stages: the first difference (None), and what
    reproduced, as a line for the success message."""
    runs = iterations = 0
    for k, stage in enumerate(session.model.earlier, start=1):
        if stage.kind != "run":
            continue
        problem = session.model.problem.model_copy(update={"parameters": stage.parameters})
        model = session.model.model_copy(
            update={
                "problem": problem,
                "algorithm": stage.algorithm,
                "records": stage.records,
                "current_iteration": len(stage.records),
                "state": None,
                "earlier": [],
            }
        )
        built = build_problem(problem, folder(session), allow_outside_tables=session.allow_outside_tables or None)
        result = replay(Session(model, built, session.path, allow_outside_tables=session.allow_outside_tables))
        if not result.ok:
            return f"earlier stage {k} (a {stage.algorithm.name} run): {result.message}", ""
        runs, iterations = runs + 1, iterations + result.iterations
    broken = chain_break(session)
    if broken:
        return f"the stages do not lead from one to the next: {broken}", ""
    hands = sum(stage.kind == "hand" for stage in session.model.earlier)
    if not session.model.earlier:
        return None, ""
    return None, f"\nand the {iterations} iterations of {runs} earlier run(s), with {hands} hand move(s) between"


def _settings_difference(k: int, old: dict, snapshot: dict) -> str | None:
    if "settings" not in old:
        return None
    found = difference(old["settings"], snapshot, "settings")
    return (
        None
        if found is None
        else (f"settings mismatch: iteration {k} was recorded with other settings than the session's: {found}")
    )


def _finished_early(k: int, state: State) -> str | None:
    if not state.status.finished:
        return None
    return f"iteration {k} diverges: recorded, but the replayed run ended at iteration {k - 1} ({state.status.value})"


def _record_difference(k: int, old: dict, new: dict) -> str | None:
    if old.get("iteration") != new["iteration"]:
        return (
            f"iteration {k} diverges: iteration: {old.get('iteration')!r} recorded, {new['iteration']!r} now "
            "(the records are out of order)"
        )
    found = difference(old, new)
    if found is None:
        return None
    if found.startswith("measures["):
        index = int(found[len("measures[") : found.index("]")])
        m = old["measures"][index] if index < len(old.get("measures", [])) else {}
        found = f"measure {m.get('name')} ({m.get('kind')}, {m.get('condition')}), {found}"
    elif found.startswith("parameters."):
        found = "parameter " + found.removeprefix("parameters.")
    return f"iteration {k} diverges: {found}"


def _state_difference(saved: dict | None, state: State, k: int) -> str | None:
    if saved is None:
        return None
    found = difference(saved, state.to_json(), "state")
    return None if found is None else f"the saved state diverges from the replayed one after iteration {k}: {found}"


def _success(model: SessionModel) -> str:
    n = len(model.records)
    text = f"all {n} recorded iterations reproduce"
    if model.state is not None:
        text += ", and the saved state"
    missing = sum("settings" not in r for r in model.records)
    if missing:
        text += (
            f"\nnote: {missing} of the {n} records do not say which settings made them "
            "(made before records kept their settings): those settings are not checked"
        )
    return text

"""What the command line's modules share: their error, JSON numbers, loading
a session, and the tableau of an iteration (iteration 0 from the
algorithm's presenter)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from engine.stepping.memory_fields import finite_or_none

if TYPE_CHECKING:
    from engine.stepping.protocol import MeasureRow, StepRecord
    from sessions.store import Session


class CliError(Exception):
    """Bad input on the command line: printed as one line, exit status 2."""


def load(file: str) -> Session:
    """Load a session; say so when a newer autosave sits beside it."""
    from sessions.store import autosave_candidate, load_session

    session = load_session(file)
    for message in session.messages:
        print(f"note: {message}", file=sys.stderr)
    autosave = autosave_candidate(file)
    if autosave is not None:
        print(
            f"note: {autosave.name} is newer than {Path(file).name}; open it to recover unsaved work", file=sys.stderr
        )
    return session


def check_session_out(session: Session, out: str | None, force: bool) -> None:
    """A command that saves its session (run, set, tune, sweep): without ``out`` it updates
    the session in place, atomically; ``out`` is checked before any work as every output
    is (`sessions.format.save_file.check_output`: no input, a regular file, --force to replace)."""
    from sessions.format.save_file import check_output
    from sessions.store import files_read

    if out is not None:
        check_output(Path(out), files_read(session), force)


def initial_record(session: Session) -> StepRecord | None:
    """Iteration 0 as the algorithm's presenter gives it (cip: the report's Table 1;
    projection: the untrimmed open loop; others: the tableau at the start)."""
    from engine.errors import EngineError
    from engine.stepping.driver import first_record
    from sessions.lifecycle import registration, stepper

    try:
        return first_record(registration(session).presenter, stepper(session))
    except EngineError as exc:
        raise CliError(f"initial tableau: {exc}") from None


def rows_now(session: Session, iteration: int | None = None) -> tuple[list[MeasureRow], StepRecord | None]:
    """The tableau at an iteration (the current one by default) and its record
    (iteration 0's record, when the algorithm gives one)."""
    records = session.records[: session.model.current_iteration]
    iteration = len(records) if iteration is None else iteration
    if not 0 <= iteration <= len(records):
        raise CliError(f"--iteration: {iteration} is outside 0..{len(records)}")
    record = records[iteration - 1] if iteration else initial_record(session)
    if record is None:
        raise CliError("initial tableau: the loop cannot be evaluated at the start")
    return list(record.measures), record


def summary_json(session: Session) -> dict:
    """`run --json` and `report --format json`: status, parameters, objective, measures, counters."""
    rows, record = rows_now(session)
    started = record.iteration > 0
    return {
        "algorithm": session.model.algorithm.name,
        "status": record.status.value if started else "not started",
        "iterations": session.model.current_iteration,
        "parameters": dict(record.parameters) if started else session.problem.named(),
        "objective": record.objective if started else None,
        "measures": [
            {
                "name": r.name,
                "kind": r.kind,
                "condition": r.condition,
                "value": finite_or_none(r.value),
                "target": r.desired,  # the JSON key other programs read
                "desired": r.desired,
                "satisfied": r.satisfied,
                "frequency": finite_or_none(r.frequency),
            }
            for r in rows
        ],
        "counters": dict(record.counters) if started else {},
        "design_notes": design_notes_now(session),
    }


def design_notes_now(session: Session, iteration: int | None = None) -> list[str]:
    """The notes on the design at ``iteration`` (default: the current one): parameters at a
    bound, a compensator amplifying noise (`engine.design.notes`)."""
    from engine.design.notes import design_notes

    k = session.model.current_iteration if iteration is None else iteration
    values = dict(session.records[k - 1].parameters) if k else session.problem.named()
    return design_notes(session.problem, values)


def stop_notes_now(session: Session) -> list[str]:
    """Why the run stopped at the current iteration (`engine.design.notes.stop_notes`): the
    binding constraints, the parameters at a bound and the unmet requirements of a stalled run,
    or what to do when every desired value is reached."""
    from engine.design.notes import stop_notes

    k = session.model.current_iteration
    if not k:
        return []
    record = session.records[k - 1]
    return stop_notes(session.problem, record.status, dict(record.parameters), record.measures)

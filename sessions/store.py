"""Load, save and autosave sessions.

Loading never raises anything but `SessionError` and never writes.  It checks
the records and the state as it checks the problem (types, finite parameter
values of the problem's shape, iterations numbered 1..n, the state after the
current iteration), and refuses JSON nested more than `MAX_DEPTH` levels.

Saving is atomic (`savefile.write_atomic`: a flushed temporary file renamed
over the target, so even kill -9 leaves the old file or the new one); the
previous file is kept as ``NAME.json.bak``; a symlink is saved through and the
file's mode is kept.  A file changed on disk since it was loaded, or a
read-only one, is not overwritten unless ``force`` (`OverwriteRefused`).  Any
failure is a `SessionError` and leaves the old file intact.  Non-finite
numbers are written so that loading reads them back: inf as 1e999, nan as
"nan".  An autosave ``NAME.json.autosave`` is written beside the file the
session will be saved to during runs (at most every `AUTOSAVE_INTERVAL`
seconds, and when a run ends) and offered back when it is newer than the
session; one that cannot be written is a warning (`Session.autosave_warning`).
"""

from __future__ import annotations

import json
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from engine.design.problem import Problem
from engine.errors import shown_json
from engine.stepping.protocol import State, StepRecord
from engine.stepping.registry import lookup
from sessions.build import OutsideTable, build_problem
from sessions.errors import SessionError
from sessions.format.checks import MAX_DEPTH, check_depth, check_record_parameters, check_records, check_state, invalid
from sessions.format.json_text import dumps
from sessions.format.limits import MAX_SESSION_BYTES
from sessions.format.migrations import MIGRATIONS
from sessions.format.reading import decoded, read_regular, resolved
from sessions.format.save_file import (
    DiskStamp,
    OverwriteRefused,
    back_up,
    check_writable,
    describe,
    mode_of,
    real_path,
    refuse_overwrite,
    remove_quietly,
    stamp_of,
    sweep_stale,
    write_atomic,
)
from sessions.format.schema import SCHEMA_VERSION, SessionModel, StateSpaceBlock, TableModel

__all__ = [
    "AUTOSAVE_INTERVAL",
    "MAX_DEPTH",
    "DiskStamp",
    "OverwriteRefused",
    "Session",
    "autosave_candidate",
    "autosave_path",
    "dumps",
    "load_autosave",
    "load_session",
    "parse_session",
    "flush_autosaves",
    "prepare_save",
    "save_session",
    "tables_in",
    "files_read",
    "write_autosave",
]


@dataclass
class Session:
    """A loaded session: the validated model, the engine problem, where it lives.

    ``disk``: the file as loaded or last saved (a change on disk since is not
    overwritten without force); ``save_to``: where it will be saved when that is
    not ``path`` (``run --out``), autosaves go beside it; ``autosave_warning``: why
    the last autosave could not be written (None: it was)."""

    model: SessionModel
    problem: Problem
    path: Path | None = None
    messages: list[str] = field(default_factory=list)
    last_autosave: float = field(default=0.0, compare=False)  # monotonic time of the last autosave
    disk: DiskStamp | None = field(default=None, compare=False)
    save_to: Path | None = field(default=None, compare=False)
    autosave_warning: str | None = field(default=None, compare=False)
    allow_outside_tables: bool = field(default=False, compare=False)  # the user allowed tables outside its folder

    @property
    def records(self) -> list[StepRecord]:
        return [StepRecord.from_json(r) for r in self.model.records]

    @property
    def state(self) -> State | None:
        """The stored state, read with the algorithm's memory class (None: none stored)."""
        if self.model.state is None:
            return None
        return State.from_json(self.model.state, lookup(self.model.algorithm.name).memory_type)


def now() -> str:
    return datetime.now(UTC).replace(microsecond=0).isoformat()


def parse_session(text: str, source: str, folder: Path, allow_outside_tables: bool = False) -> Session:
    """A session from JSON text; ``source`` names it in messages, tables are read from ``folder``
    (one outside it only with ``allow_outside_tables``: `OutsideTable` otherwise)."""
    try:
        data, messages = _migrate(_json(text))
        model = validated_model(data)
        check_records(model)
        check_state(model)
        problem = build_problem(model.problem, folder, allow_outside_tables=allow_outside_tables or None)
        check_record_parameters(model, problem)
    except OutsideTable as exc:
        raise OutsideTable(f"{source}: {exc}", exc.name) from None
    except SessionError as exc:
        raise SessionError(f"{source}: {exc}") from None
    session = Session(model, problem, None, messages)
    session.allow_outside_tables = allow_outside_tables
    return session


def _json(text: str) -> Any:
    """The JSON data of a session, nested at most `MAX_DEPTH` levels."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SessionError(f"line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise SessionError(f"not readable as JSON: {exc}") from None
    except RecursionError:
        raise SessionError(f"nested more than {MAX_DEPTH} levels deep") from None
    check_depth(data)
    return data


def validated_model(data: Any) -> SessionModel:
    """The session model of JSON data, or a `SessionError` naming the first fault's JSON path."""
    try:
        return SessionModel.model_validate(data)
    except ValidationError as exc:
        raise SessionError(invalid(exc, data=data)) from None


def _migrate(data: Any) -> tuple[Any, list[str]]:
    if not isinstance(data, dict):
        raise SessionError(f"a session is a JSON object, not {shown_json(data)}")
    version = data.get("schema_version")
    if not isinstance(version, int) or isinstance(version, bool):
        raise SessionError("schema_version: missing or not an integer")
    if version > SCHEMA_VERSION:
        raise SessionError(
            f"schema_version {version} is newer than this loopcraft reads "
            f"({SCHEMA_VERSION}); update loopcraft to open it"
        )
    messages = []
    while version < SCHEMA_VERSION:
        if version not in MIGRATIONS:
            raise SessionError(f"schema_version {version} cannot be migrated")
        data = MIGRATIONS[version](dict(data))
        messages.append(f"migrated from schema version {version} to {version + 1}")
        version += 1
        data["schema_version"] = version
    return data, messages


def load_session(path: str | Path, allow_outside_tables: bool = False) -> Session:
    """Read and validate a session file; never modifies it.  Tables are read beside
    the real file (through a symlink); outside its folder only with ``allow_outside_tables``."""
    path = Path(path)
    text, stamp = _read(path)
    session = parse_session(text, str(path), real_path(path).parent, allow_outside_tables)
    session.path, session.disk = path, stamp
    return session


def load_autosave(path: str | Path, allow_outside_tables: bool = False) -> Session:
    """The autosave of ``path`` (`autosave_candidate`) as the session at ``path``: saving
    it replaces ``path``, unless that changes on disk after this; tables beside its real file."""
    path, auto = Path(path), autosave_path(Path(path))
    session = parse_session(_read(auto)[0], str(auto), real_path(path).parent, allow_outside_tables)
    session.path = path
    try:
        data, info = read_regular(path, MAX_SESSION_BYTES)
        session.disk = stamp_of(path, data, info)
    except SessionError:
        session.disk = None
    return session


def _read(path: Path) -> tuple[str, DiskStamp]:
    """A session file's text (a regular file of at most MAX_SESSION_BYTES, a BOM dropped)
    and its stamp."""
    data, info = read_regular(path, MAX_SESSION_BYTES)
    return decoded(data, path), stamp_of(path, data, info)


def save_session(session: Session, path: str | Path | None = None, *, force: bool = False) -> Path:
    """Write atomically (through a symlink, keeping the file's mode); the file it replaces
    is kept as NAME.json.bak.  Unless ``force``, a file changed on disk since it was loaded
    or a read-only one is not overwritten (`OverwriteRefused`).  Any failure is a
    `SessionError` and leaves the old file as it was."""
    target = Path(path) if path is not None else session.path
    if target is None:
        raise SessionError("no file to save to")
    real = real_path(target)
    refuse_overwrite(target, session.disk, force)
    moved = _moved_tables(session, real.parent)
    modified = now()
    text = _saved_text(session.model, moved, modified, target)
    try:
        sweep_stale(real)
        back_up(real, real.with_name(real.name + ".bak"))
        session.disk = write_atomic(real, text, mode_of(real))
    except OSError as exc:
        raise SessionError(f"{target}: cannot save: {describe(exc)}") from None
    for table, name in moved:
        table.csv = name
    session.model.provenance.modified = modified
    remove_quietly(autosave_path(target))
    if session.last_autosave and (session.save_to or session.path) is not None:  # ours, now saved in target
        remove_quietly(autosave_path(session.save_to or session.path))
    session.path, session.save_to, session.autosave_warning = target, None, None
    return target


def _saved_text(model: SessionModel, moved: list[tuple[TableModel, str]], modified: str, target: Path) -> str:
    """The JSON ``model`` is saved as: with the table names and the time it is saved
    with (the model itself is left as it is until the save succeeds)."""
    before = [(table, table.csv) for table, _ in moved], model.provenance.modified
    try:
        for table, name in moved:
            table.csv = name
        model.provenance.modified = modified
        return dumps(model)
    except (ValueError, TypeError, RecursionError) as exc:
        raise SessionError(f"{target}: cannot save: the session is not JSON data ({exc})") from None
    finally:
        for table, name in before[0]:
            table.csv = name
        model.provenance.modified = before[1]


def _moved_tables(session: Session, new: Path) -> list[tuple[TableModel, str]]:
    """CSV tables are named relative to the session's real folder: saved in another,
    each relative name is rewritten so that it still reaches the same file."""
    if session.path is None:
        return []
    old = real_path(session.path).parent
    if old == new:
        return []
    moved = []
    for table in tables_in(session.model.problem):
        if table.csv is None or Path(table.csv).is_absolute():
            continue
        source = resolved(old / table.csv)
        name = Path(os.path.relpath(source, resolved(new))).as_posix()
        if name.startswith("../") and not session.allow_outside_tables:
            name = _copy_beside(source, new)  # a table outside the new folder would be refused
        moved.append((table, name))
    return moved


def _copy_beside(source: Path, folder: Path) -> str:
    """Copy a table into ``folder`` under its own name (a suffix when another file has it)."""
    data = source.read_bytes()
    stem, k = source.stem, 1
    target = folder / source.name
    while target.exists() and target.read_bytes() != data:
        k += 1
        target = folder / f"{stem}-{k}{source.suffix}"
    if not target.exists():
        target.write_bytes(data)
    return target.name


def prepare_save(session: Session, target: str | Path, force: bool = False) -> None:
    """Before the work: a `SessionError` now when ``target`` cannot be saved to (its
    folder missing or not writable, a read-only file unless ``force``); autosaves
    go beside it from now on."""
    check_writable(Path(target), force)
    session.save_to = Path(target)


def tables_in(node: Any):
    """Every `TableModel` inside a model (plants, channels, cascades, objective)."""
    yield from models_in(node, TableModel)


def models_in(node: Any, kind: type[BaseModel]):
    """Every model of type ``kind`` inside a model (plants, channels, cascades, objective)."""
    if isinstance(node, kind):
        yield node
    elif isinstance(node, BaseModel):
        for name in type(node).model_fields:
            yield from models_in(getattr(node, name), kind)
    elif isinstance(node, (list, tuple)):
        for item in node:
            yield from models_in(item, kind)
    elif isinstance(node, dict):
        for item in node.values():
            yield from models_in(item, kind)


def files_read(session: Session) -> dict[Path, str]:
    """Every file a command on ``session`` reads (path -> what it is): the session and the
    CSV tables and state-space files it names (beside its real file), which no output may replace."""
    if session.path is None:
        return {}
    folder = real_path(session.path).parent
    files = {session.path: "the session"}
    files |= {folder / t.csv: f"the session's table {t.csv}" for t in tables_in(session.model.problem) if t.csv}
    blocks = models_in(session.model.problem, StateSpaceBlock)
    files |= {folder / b.file: f"the session's state-space file {b.file}" for b in blocks if b.file}
    return files


def autosave_path(path: Path) -> Path:
    """Where the autosave of a session file goes: beside its real file."""
    real = real_path(Path(path))
    return real.with_name(real.name + ".autosave")


AUTOSAVE_INTERVAL = 2.0  # s: a long run is autosaved this often (and at its end), not every iteration


def write_autosave(session: Session, at_most_every: float = 0.0, wait: bool = True) -> Path | None:
    """The whole session beside the file it will be saved to (never over it).  With
    ``at_most_every``, nothing is written when the last autosave is more recent than
    that (the whole session is written each time, so per-iteration writes would grow
    as n^2).  The session is copied at once (its record list; everything else is
    replaced, never changed in place) and written by one background thread, in
    order (``wait``: this call waits for it; else it returns the planned path and
    the app's UI thread goes on; each record's text is kept, `sessions.format.json_text`).
    Never raises: one that cannot be written gives None, and
    ``session.autosave_warning`` says why (None again after one that succeeds)."""
    base = session.save_to or session.path
    if base is None:
        return None
    now_ = time.monotonic()
    if at_most_every and session.last_autosave and now_ - session.last_autosave < at_most_every:
        return None
    target = autosave_path(base)
    session.last_autosave = now_  # a failed one too: a full disk is not tried again every iteration
    snapshot = session.model.model_copy(update={"records": list(session.model.records)})
    written = _writer().submit(_write_autosave, session, target, snapshot, mode_of(real_path(base)))
    return written.result() if wait else target


def flush_autosaves() -> None:
    """Wait until every autosave asked for is written (before the app exits, and in tests)."""
    _writer().submit(lambda: None).result()


_WRITER: list[ThreadPoolExecutor] = []


def _writer() -> ThreadPoolExecutor:
    """The one thread that writes autosaves, in the order they were asked for."""
    if not _WRITER:
        _WRITER.append(ThreadPoolExecutor(max_workers=1, thread_name_prefix="autosave"))
    return _WRITER[0]


def _write_autosave(session: Session, target: Path, snapshot: SessionModel, mode: int | None) -> Path | None:
    try:
        write_atomic(target, dumps(snapshot, compact=True), mode)
    except (OSError, ValueError, TypeError, RecursionError) as exc:
        reason = describe(exc) if isinstance(exc, OSError) else f"the session is not JSON data ({exc})"
        session.autosave_warning = f"{target}: cannot autosave: {reason}"
        return None
    session.autosave_warning = None
    return target


def set_aside_autosave(path: str | Path) -> Path:
    """Rename the autosave of ``path`` (declined at recovery) to
    ``NAME.autosave.declined-YYYYMMDD-HHMMSS`` beside it, so it is not offered again
    and not lost; the new path."""
    auto = autosave_path(Path(path))
    target = auto.with_name(f"{auto.name}.declined-{time.strftime('%Y%m%d-%H%M%S')}")
    try:
        auto.rename(target)
    except OSError as exc:
        raise SessionError(f"{auto}: cannot set the autosave aside: {describe(exc)}") from None
    return target


def autosave_candidate(path: str | Path) -> Path | None:
    """The autosave of ``path`` when it is newer than the file itself."""
    path = Path(path)
    auto = autosave_path(path)
    try:
        if not auto.exists():
            return None
        if not path.exists() or auto.stat().st_mtime > path.stat().st_mtime:
            return auto
    except OSError:
        return None
    return None

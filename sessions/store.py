"""Load, save and autosave sessions.

Loading never raises anything but `SessionError` and never writes.  Saving is
atomic: the JSON goes to a temporary file in the same folder, is flushed to
disk, and replaces the target by a rename; the previous file is kept as
``NAME.json.bak``.  An autosave ``NAME.json.autosave`` is written during runs (at most every
`AUTOSAVE_INTERVAL` seconds, and when a run ends) and offered back when it
is newer than the session.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from engine.algorithm import State, StepRecord, memory_type
from engine.errors import EngineError
from engine.problem import Problem

from .build import build_problem
from .errors import SessionError
from .schema import SCHEMA_VERSION, SessionModel, TableModel

# version -> function turning a session dict of that version into the next version's
MIGRATIONS: dict[int, Callable[[dict], dict]] = {}


@dataclass
class Session:
    """A loaded session: the validated model, the engine problem, where it lives."""

    model: SessionModel
    problem: Problem
    path: Path | None = None
    messages: list[str] = field(default_factory=list)
    last_autosave: float = field(default=0.0, compare=False)   # monotonic time of the last autosave

    @property
    def records(self) -> list[StepRecord]:
        return [StepRecord.from_json(r) for r in self.model.records]

    @property
    def state(self) -> State | None:
        """The stored state, read with the algorithm's memory class (None: none stored)."""
        if self.model.state is None:
            return None
        return State.from_json(self.model.state, memory_type(self.model.algorithm.name))


def now() -> str:
    return datetime.now(timezone.utc).replace(microsecond=0).isoformat()


def _location(loc: tuple) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top)"


def parse_session(text: str, source: str, folder: Path) -> Session:
    """A session from JSON text; ``source`` names it in messages."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SessionError(f"{source}: line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise SessionError(f"{source}: nested too deeply") from None
    data, messages = _migrate(data, source)
    try:
        model = SessionModel.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
        msg = first["msg"].removeprefix("Value error, ")
        raise SessionError(f"{source}: {_location(first['loc'])}: {msg}{more}") from None
    for i, record in enumerate(model.records):
        try:
            StepRecord.from_json(record)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise SessionError(f"{source}: records[{i}]: malformed record ({exc})") from None
    if model.current_iteration > len(model.records):
        raise SessionError(f"{source}: current_iteration {model.current_iteration} exceeds "
                           f"the {len(model.records)} records")
    _check_state(model, source)
    try:
        problem = build_problem(model.problem, folder)
    except SessionError as exc:
        raise SessionError(f"{source}: {exc}") from None
    return Session(model, problem, None, messages)


def _check_state(model: SessionModel, source: str) -> None:
    """A stored state must read back with its algorithm's memory class (an unknown
    algorithm is reported when the session is run, not here)."""
    if model.state is None:
        return
    try:
        kind = memory_type(model.algorithm.name)
    except EngineError:
        return
    try:
        State.from_json(model.state, kind)
    except EngineError as exc:
        raise SessionError(f"{source}: state: {exc}") from None


def _migrate(data: Any, source: str) -> tuple[Any, list[str]]:
    if not isinstance(data, dict):
        raise SessionError(f"{source}: a session is a JSON object, not {type(data).__name__}")
    version = data.get("schema_version")
    if not isinstance(version, int) or isinstance(version, bool):
        raise SessionError(f"{source}: schema_version: missing or not an integer")
    if version > SCHEMA_VERSION:
        raise SessionError(f"{source}: schema_version {version} is newer than this loopcraft reads "
                           f"({SCHEMA_VERSION}); update loopcraft to open it")
    messages = []
    while version < SCHEMA_VERSION:
        if version not in MIGRATIONS:
            raise SessionError(f"{source}: schema_version {version} cannot be migrated")
        data = MIGRATIONS[version](dict(data))
        messages.append(f"migrated from schema version {version} to {version + 1}")
        version += 1
        data["schema_version"] = version
    return data, messages


def load_session(path: str | Path) -> Session:
    """Read and validate a session file; never modifies it."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SessionError(f"{path}: cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    session = parse_session(text, str(path), path.parent)
    session.path = path
    return session


def dumps(model: SessionModel) -> str:
    """Stable JSON: sorted keys, shortest float repr, two-space indent."""
    data = model.model_dump(mode="json", exclude_none=False)
    return json.dumps(data, indent=2, sort_keys=True, allow_nan=False) + "\n"


def _atomic_write(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    try:
        dir_fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
    except OSError:
        pass


def save_session(session: Session, path: str | Path | None = None) -> Path:
    """Write atomically; the file it replaces is kept as NAME.json.bak."""
    target = Path(path) if path is not None else session.path
    if target is None:
        raise SessionError("no file to save to")
    if session.path is not None and target.parent.resolve() != session.path.parent.resolve():
        _rebasetables_in(session.model, session.path.parent, target.parent)
    session.model.provenance.modified = now()
    text = dumps(session.model)
    for stale in target.parent.glob(f".{target.name}.*tmp"):  # left by a save that was killed
        stale.unlink(missing_ok=True)
    try:
        if target.exists():
            _atomic_write(target.with_name(target.name + ".bak"), target.read_text(encoding="utf-8"))
        _atomic_write(target, text)
    except OSError as exc:
        raise SessionError(f"{target}: cannot save: {exc.strerror or exc}") from None
    autosave_path(target).unlink(missing_ok=True)
    if session.path is not None and session.last_autosave:  # ours, and now saved in target
        autosave_path(session.path).unlink(missing_ok=True)
    session.path = target
    return target


def _rebasetables_in(model: SessionModel, old: Path, new: Path) -> None:
    """CSV tables are named relative to the session: saved elsewhere, the
    names are rewritten so they still reach the same files."""
    for table in tables_in(model.problem):
        if table.csv is not None and not Path(table.csv).is_absolute():
            table.csv = Path(os.path.relpath((old / table.csv).resolve(), new.resolve())).as_posix()


def tables_in(node: Any):
    """Every `TableModel` inside a model (plants, channels, cascades, objective)."""
    if isinstance(node, TableModel):
        yield node
    elif isinstance(node, BaseModel):
        for name in type(node).model_fields:
            yield from tables_in(getattr(node, name))
    elif isinstance(node, (list, tuple)):
        for item in node:
            yield from tables_in(item)
    elif isinstance(node, dict):
        for item in node.values():
            yield from tables_in(item)


def autosave_path(path: Path) -> Path:
    return path.with_name(path.name + ".autosave")


AUTOSAVE_INTERVAL = 2.0   # s: a long run is autosaved this often (and at its end), not every iteration


def write_autosave(session: Session, at_most_every: float = 0.0) -> Path | None:
    """The whole session beside its file (never over it).  With ``at_most_every``,
    nothing is written when the last autosave is more recent than that (the whole
    session is written each time, so per-iteration writes would grow as n^2)."""
    if session.path is None:
        return None
    now_ = time.monotonic()
    if at_most_every and session.last_autosave and now_ - session.last_autosave < at_most_every:
        return None
    target = autosave_path(session.path)
    _atomic_write(target, dumps(session.model))
    session.last_autosave = now_
    return target


def autosave_candidate(path: str | Path) -> Path | None:
    """The autosave of ``path`` when it is newer than the file itself."""
    path = Path(path)
    auto = autosave_path(path)
    if not auto.exists():
        return None
    if not path.exists() or auto.stat().st_mtime > path.stat().st_mtime:
        return auto
    return None

"""Where the app keeps things: the bundled examples (never written to), the
working copies it opens instead, the list of recent sessions, and the
template of a new session.  ``LOOPCRAFT_HOME`` (default ~/.loopcraft) is the
app's own folder."""

from __future__ import annotations

import json
import os
import shutil
import stat
from pathlib import Path

from sessions.format.save_file import describe

EXAMPLES = Path(__file__).resolve().parent.parent / "sessions" / "examples"
RECENT_LIMIT = 10


def home() -> Path:
    return Path(os.environ.get("LOOPCRAFT_HOME", Path.home() / ".loopcraft"))


def working_copy(path: Path) -> Path:
    """A bundled example is copied (with the tables beside it) before it is opened."""
    path = path.resolve()
    if path.parent != EXAMPLES.resolve():
        return path
    target = home() / "examples"
    target.mkdir(parents=True, exist_ok=True)
    for f in EXAMPLES.iterdir():
        if f.suffix == ".csv" and not (target / f.name).exists():
            shutil.copy2(f, target / f.name)
    if not (target / path.name).exists():
        shutil.copy2(path, target / path.name)
    return target / path.name


def example(name: str) -> Path:
    """The working copy of a bundled example by name (with or without .json)."""
    path = EXAMPLES / (name if name.endswith(".json") else f"{name}.json")
    if not path.exists():
        known = ", ".join(sorted(p.stem for p in EXAMPLES.glob("*.json")))
        raise FileNotFoundError(f"no bundled example {name!r}; examples: {known}")
    return working_copy(path)


def recent_limit() -> int:
    """How many recent sessions are kept (the config's recent_limit; a config that does not read: the default)."""
    from tui.config import ConfigError, load_config

    try:
        return load_config().recent_limit
    except ConfigError:
        return RECENT_LIMIT


def recent_sessions() -> list[Path]:
    try:
        items = json.loads((home() / "recent.json").read_text())
    except (OSError, ValueError):
        return []
    return [Path(p) for p in items if isinstance(p, str) and file_problem(Path(p)) is None][: recent_limit()]


def remember(path: Path) -> None:
    """Put a session at the top of the recent list (best effort)."""
    items = [str(path.resolve())] + [str(p) for p in recent_sessions() if p.resolve() != path.resolve()]
    try:
        home().mkdir(parents=True, exist_ok=True)
        (home() / "recent.json").write_text(json.dumps(items[: recent_limit()], indent=1))
    except OSError:
        pass


def file_problem(path: Path) -> str | None:
    """None when ``path`` names a regular file; else why not, in words ("no such file",
    "File name too long (ENAMETOOLONG)"): never raises, whatever the user typed."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return "no such file"
    except OSError as exc:
        return describe(exc)
    except ValueError:  # a NUL in the text
        return "not a file name"
    return None if stat.S_ISREG(info.st_mode) else "not a regular file"


def untitled_path() -> Path:
    """Where a new session lives until it is saved elsewhere (its autosave goes beside it)."""
    folder = home() / "new"
    folder.mkdir(parents=True, exist_ok=True)
    k = 1
    while (folder / f"untitled-{k}.json").exists() or (folder / f"untitled-{k}.json.autosave").exists():
        k += 1
    return folder / f"untitled-{k}.json"

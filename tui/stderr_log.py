"""While the workbench runs, whatever the process or its children write to standard
error goes to a log file (`log_path`), never over the screen: Dask's worker logs and
tracebacks (a worker process inherits descriptor 2), a library's logging handler made
before the app started (it holds the old `sys.stderr`), a warning.  Textual draws on
`sys.__stderr__`, so that stream is moved to a copy of the terminal's descriptor and
descriptor 2 is pointed at the log; both are put back when the app ends."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tui.files import home

LOG_NAME = "loopcraft.log"


def log_path() -> Path:
    """Where the workbench's standard error goes while it runs (the help names it)."""
    return home() / LOG_NAME


def log_path_text() -> str:
    """The log's path as the help writes it: under ``$LOOPCRAFT_HOME`` when that is set,
    else under ``~/.loopcraft`` (the same file as `log_path`, and the same text on every machine)."""
    return f"$LOOPCRAFT_HOME/{LOG_NAME}" if os.environ.get("LOOPCRAFT_HOME") else f"~/.loopcraft/{LOG_NAME}"


@contextmanager
def stderr_to_log(path: Path | None = None) -> Iterator[Path]:
    """Standard error (descriptor 2) into ``path`` (appended), the terminal kept for
    Textual on ``sys.__stderr__``; a log that cannot be opened leaves everything as it was."""
    path = log_path() if path is None else path
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        log = open(path, "a", buffering=1, encoding="utf-8", errors="backslashreplace")  # noqa: SIM115
    except OSError:
        yield path
        return
    for stream in (sys.stderr, sys.__stderr__):
        if stream is not None:
            stream.flush()
    saved_fd, saved_stream = os.dup(2), sys.__stderr__
    terminal = os.fdopen(os.dup(2), "w", buffering=1, encoding="utf-8", errors="backslashreplace")
    log.write(f"--- loopcraft {time.strftime('%Y-%m-%d %H:%M:%S')} (pid {os.getpid()})\n")
    os.dup2(log.fileno(), 2)
    sys.__stderr__ = terminal
    try:
        yield path
    finally:
        for stream in (sys.stderr, terminal):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os.dup2(saved_fd, 2)
        os.close(saved_fd)
        sys.__stderr__ = saved_stream
        terminal.close()
        log.close()

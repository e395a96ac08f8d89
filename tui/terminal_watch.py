"""The workbench's terminal going away (an SSH connection dropped, a tmux
server killed).  Textual's input thread reads end-of-file from a hung-up
terminal in a tight loop, so an app whose hang-up signal went elsewhere (to
`make`, its parent) kept a core busy for good.  `watch_terminal` ends the
app instead: on SIGHUP, or when standard input stops being a terminal
(checked every `CHECK_INTERVAL_S`)."""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import sys
from collections.abc import Callable

from textual.app import App

CHECK_INTERVAL_S = 1.0
HANGUP_EXIT = 128 + signal.SIGHUP   # the shell's status for a process ended by a hang-up


def watch_terminal(app: App, lost: Callable[[], None]) -> None:
    """Call ``lost`` once when the terminal ``app`` runs on hangs up; nothing for
    a headless app (tests, snapshots) or one not started on a terminal."""
    if app.is_headless or not terminal_attached():
        return
    fired = False

    def once() -> None:
        nonlocal fired
        if not fired:
            fired = True
            lost()

    with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):   # no signals here (not Unix)
        asyncio.get_running_loop().add_signal_handler(signal.SIGHUP, once)
    app.set_interval(CHECK_INTERVAL_S, lambda: None if terminal_attached() else once())


def terminal_attached() -> bool:
    """Is standard input still a terminal?  (A hung-up terminal answers none of
    its requests: `os.isatty` is then False.)"""
    try:
        return os.isatty(sys.__stdin__.fileno())
    except (AttributeError, ValueError, OSError):
        return False

"""The workbench's terminal going away (an SSH connection dropped, a tmux
server killed).  Textual's input thread reads end-of-file from a hung-up
terminal in a tight loop, so an app whose hang-up signal went elsewhere (to
`make`, its parent) kept a core busy for good; and its output thread dies on
the first write that fails, after which the app's next writes (its closing
ones too) wait for good.  `watch_terminal` ends the app instead, on SIGHUP or
when standard input stops being a terminal (a thread checks every
`CHECK_INTERVAL_S`): standard output and error go to /dev/null, the app is
asked to save and end on its own loop, and the process ends outright after
`GRACE_S` if the app could not."""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Callable

from textual.app import App

CHECK_INTERVAL_S = 1.0
GRACE_S = 10.0  # for the app to save and end before the process is ended outright
HANGUP_EXIT = 128 + signal.SIGHUP  # the shell's status for a process ended by a hang-up


def watch_terminal(app: App, lost: Callable[[], None]) -> None:
    """Call ``lost`` once, on the app's loop, when the terminal ``app`` runs on
    hangs up; nothing for a headless app (tests, snapshots) or one not started
    on a terminal."""
    if app.is_headless or not terminal_attached():
        return
    loop = asyncio.get_running_loop()
    ending = threading.Event()

    def end() -> None:  # on the loop (SIGHUP) or the watching thread, whichever notices first
        if not ending.is_set():
            ending.set()
            _ended(loop, lost)

    with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):  # no signals here (not Unix)
        loop.add_signal_handler(signal.SIGHUP, end)
    threading.Thread(target=_watch, args=(end,), name="terminal-watch", daemon=True).start()


def terminal_attached() -> bool:
    """Is standard input still a terminal?  (A hung-up terminal answers none of
    its requests: `os.isatty` is then False.)"""
    try:
        return os.isatty(sys.__stdin__.fileno())
    except (AttributeError, ValueError, OSError):
        return False


def _watch(end: Callable[[], None]) -> None:
    while terminal_attached():
        time.sleep(CHECK_INTERVAL_S)
    end()


def _ended(loop: asyncio.AbstractEventLoop, lost: Callable[[], None]) -> None:
    """The terminal is gone (once): writes go nowhere, ``lost`` runs on the app's loop,
    and the process ends outright after `GRACE_S` if the app has not."""
    with contextlib.suppress(OSError):
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.dup2(null, 2)
        os.close(null)
    with contextlib.suppress(RuntimeError):  # the loop already closed: the app has ended
        loop.call_soon_threadsafe(lost)
    timer = threading.Timer(GRACE_S, os._exit, (HANGUP_EXIT,))
    timer.daemon = True
    timer.start()

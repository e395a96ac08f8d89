"""The real `loopcraft` on a pseudo-terminal that goes away (an SSH connection
dropped, a tmux server killed): the app keeps its unsaved step in the
autosave and exits 129, whether or not the hang-up signal reaches it; it
used to spin on the dead terminal for good."""

from __future__ import annotations

import json
import os
import pty
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tui.terminal_watch import HANGUP_EXIT

EXAMPLE = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "report003_lag_lead.json"
pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="pseudo-terminals of Linux")


def drain(fd: int, seconds: float, until: bytes | None = None) -> bytes:
    """What the app writes to the terminal for ``seconds`` (or until ``until`` shows)."""
    end, data = time.monotonic() + seconds, b""
    while time.monotonic() < end and not (until and until in data):
        if select.select([fd], [], [], 0.1)[0]:
            try:
                data += os.read(fd, 65536)
            except OSError:
                break
    return data


def started(tmp_path: Path) -> tuple[subprocess.Popen, int, Path]:
    """The app on a copy of report 003's session, on a new pseudo-terminal that is
    not its controlling terminal (so closing it sends no hang-up signal), one step taken."""
    session = tmp_path / EXAMPLE.name
    shutil.copy2(EXAMPLE, session)
    master, slave = pty.openpty()
    env = dict(os.environ, TERM="xterm-256color", LOOPCRAFT_HOME=str(tmp_path / "home"), COLUMNS="120", LINES="40")
    app = subprocess.Popen(
        [sys.executable, "-m", "tui.cli", str(session)],
        stdin=slave,
        stdout=slave,
        stderr=slave,
        cwd=Path(__file__).resolve().parents[2],
        env=env,
    )
    os.close(slave)
    assert b"Iteration 0" in drain(master, 30, until=b"Iteration 0"), "the app never painted"
    os.write(master, b"s")
    assert b"Iteration 1" in drain(master, 30, until=b"Iteration 1"), "the step never showed"
    return app, master, session


def ended(app: subprocess.Popen) -> int | None:
    try:
        return app.wait(timeout=15)
    except subprocess.TimeoutExpired:
        app.kill()
        return None


def test_a_terminal_that_hangs_up_ends_the_app_with_its_work_autosaved(tmp_path):
    app, master, session = started(tmp_path)
    os.close(master)  # the terminal is gone; no signal: the app notices by itself
    assert ended(app) == HANGUP_EXIT
    autosave = json.loads(session.with_name(session.name + ".autosave").read_text())
    assert autosave["current_iteration"] == 1 and len(autosave["records"]) == 1
    assert json.loads(session.read_text())["records"] == []  # the file itself is untouched


def test_a_hang_up_signal_ends_the_app_with_its_work_autosaved(tmp_path):
    app, master, session = started(tmp_path)
    try:
        app.send_signal(signal.SIGHUP)
        assert ended(app) == HANGUP_EXIT
    finally:
        os.close(master)
    assert json.loads(session.with_name(session.name + ".autosave").read_text())["current_iteration"] == 1


class _Terminal:
    """Standard input or output as the workbench's start sees it: a terminal."""

    def isatty(self) -> bool:
        return True


def test_an_app_ended_by_a_write_to_the_hung_up_terminal_exits_129_with_its_work_autosaved(tmp_path, monkeypatch):
    """The race the pseudo-terminal test above lost once under load (exit 1): the app's last write
    to the terminal fails (EIO) before the terminal watch's next look; whatever ended the app once
    its terminal is gone, the step it took is in the autosave and the exit is the hang-up's."""
    import tui.terminal_watch
    from sessions.store import load_session
    from tui.app import LoopcraftApp
    from tui.cli import run_app
    from tui.state.workbench import Workbench

    session = tmp_path / EXAMPLE.name
    shutil.copy2(EXAMPLE, session)
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    monkeypatch.setattr(sys, "stdin", _Terminal())
    monkeypatch.setattr(sys, "stdout", _Terminal())
    monkeypatch.setattr(tui.terminal_watch, "terminal_attached", lambda: False)

    def run(self):  # one step taken, then the terminal's write fails
        self.bench = Workbench(load_session(session))
        self.bench.step()
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(LoopcraftApp, "run", run)
    assert run_app(str(session)) == HANGUP_EXIT
    autosave = json.loads(session.with_name(session.name + ".autosave").read_text())
    assert autosave["current_iteration"] == 1 and len(autosave["records"]) == 1
    assert json.loads(session.read_text())["records"] == []

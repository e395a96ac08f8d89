"""End to end: the real `loopcraft` in a tmux terminal, driven by keys."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

TMUX = shutil.which("tmux")
LOOPCRAFT = Path(sys.executable).parent / "loopcraft"
pytestmark = pytest.mark.skipif(
    TMUX is None, reason="tmux is not installed (.ci/run installs it): end-to-end test skipped"
)


def tmux(*args: str) -> str:
    return subprocess.run([TMUX, *args], capture_output=True, text=True, check=False).stdout


HUNG = 900.0  # s: only a hung app reaches this; each wait is for a condition, however loaded the machine


def wait_until(condition: Callable[[], bool], what: Callable[[], str]) -> None:
    """Poll ``condition`` until it holds (``what``: the failure's message, should the app hang)."""
    deadline = time.monotonic() + HUNG
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(what())
        time.sleep(0.2)


def wait_for(session: str, *texts: str) -> str:
    """The screen once every one of ``texts`` is on it (a screen half drawn is not yet it)."""
    screens = [""]

    def shown() -> bool:
        screens[0] = tmux("capture-pane", "-t", session, "-p")
        return all(text in screens[0] for text in texts)

    wait_until(shown, lambda: f"{texts!r} never appeared; the screen:\n{screens[0]}")
    return screens[0]


def test_open_step_three_times_save_and_quit(workdir):
    session = f"loopcraft-e2e-{time.monotonic_ns()}"
    exit_file = workdir / "exit.txt"
    command = (
        f"cd {workdir} && LOOPCRAFT_HOME={workdir / 'home'} TERM=xterm-256color {LOOPCRAFT} "
        f"seidel_inlet_pi.json; echo EXIT:$? > {exit_file}.tmp && mv {exit_file}.tmp {exit_file}"  # whole or absent
    )
    tmux("new-session", "-d", "-s", session, "-x", "120", "-y", "40", command)
    tmux("set-option", "-t", session, "window-size", "manual")
    tmux("resize-window", "-t", session, "-x", "120", "-y", "40")
    try:
        wait_for(session, "Iteration 0")
        for k in (1, 2, 3):
            tmux("send-keys", "-t", session, "s")
            screen = wait_for(session, f"Iteration {k}")
        screen = wait_for(session, "objective 0.05")  # the cost C after three line searches
        assert "Iteration 3" in screen
        tmux("send-keys", "-t", session, "C-s")
        wait_for(session, "saved")
        tmux("send-keys", "-t", session, "q")
        wait_until(exit_file.exists, lambda: "the app never exited")
        assert exit_file.read_text().strip() == "EXIT:0"
        assert len(json.loads((workdir / "seidel_inlet_pi.json").read_text())["records"]) == 3
    finally:
        tmux("kill-session", "-t", session)


@pytest.mark.long
def test_every_tab_is_readable_at_80x24(workdir):
    """At 80x24: the tableau's target and frequency columns, each tab's key columns and the
    footer's ? and save are on the screen."""
    session = f"loopcraft-e2e-{time.monotonic_ns()}"
    command = (
        f"cd {workdir} && LOOPCRAFT_HOME={workdir / 'home'} TERM=xterm-256color {LOOPCRAFT} coebra_launch_vehicle.json"
    )
    tmux("new-session", "-d", "-s", session, "-x", "80", "-y", "24", command)
    tmux("set-option", "-t", session, "window-size", "manual")
    tmux("resize-window", "-t", session, "-x", "80", "-y", "24")
    expected = {
        "1": ["target", "freq rad/s", "PM deg"],
        "2": ["condition", "block", "parameter", "min"],
        "3": ["measure", "used", "bands", "objective / setting"],
        "4": ["iteration", "status", "unmet"],
        "5": ["no sweep yet"],
    }
    try:
        wait_for(session, "Iteration 0")
        for key, words in expected.items():
            tmux("send-keys", "-t", session, key)
            screen = wait_for(session, *words, "? help", "^s save")
            footer = screen.rstrip().splitlines()[-1]
            assert "? help" in footer and "^s save" in footer, (key, footer)
    finally:
        tmux("kill-session", "-t", session)

"""End to end: the real `loopcraft` in a tmux terminal, driven by keys."""

from __future__ import annotations

import json
import math
import os
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


def start(session: str, columns: int, rows: int, command: str) -> None:
    """``command`` in a new detached session whose pane has its size before the command starts,
    without COLUMNS and LINES: the app reads them first when they are set (Textual asks
    `shutil.get_terminal_size`), and a tmux server started from a shell that exports them hands
    them to every pane (the drag test's app drew 80x24 in a 120x40 pane, its mouse reports landed
    beside the marks and it waited 900 s for an edit); a detached session also takes the server's
    default size until it is resized."""
    tmux("new-session", "-d", "-s", session, "-x", str(columns), "-y", str(rows), "cat")
    tmux("set-option", "-t", session, "window-size", "manual")
    tmux("resize-window", "-t", session, "-x", str(columns), "-y", str(rows))
    tmux("respawn-pane", "-k", "-t", session, f"unset COLUMNS LINES; {command}")


def test_open_step_three_times_save_and_quit(workdir):
    session = f"loopcraft-e2e-{time.monotonic_ns()}"
    exit_file = workdir / "exit.txt"
    command = (
        f"cd {workdir} && LOOPCRAFT_HOME={workdir / 'home'} TERM=xterm-256color {LOOPCRAFT} "
        f"seidel_inlet_pi.json; echo EXIT:$? > {exit_file}.tmp && mv {exit_file}.tmp {exit_file}"  # whole or absent
    )
    start(session, 120, 40, command)
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
    start(session, 80, 24, command)
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


def _sgr(session: str, button: int, col: int, row: int, release: bool = False) -> None:
    """An xterm SGR mouse report (1-based cell) typed into the pane, as a terminal sends it."""
    tmux("send-keys", "-t", session, "-l", f"\x1b[<{button};{col};{row}{'m' if release else 'M'}")


def _shown_number(screen: str, label: str) -> str:
    """The value after ``label`` on the tableau's row (the first such row)."""
    line = next(line for line in screen.splitlines() if label in line)
    return line.split(label, 1)[1].split()[0]


def _half_digit(text: str) -> float:
    """Half the last digit shown: how far a number shown may be from the exact one."""
    return 0.5 * 10.0 ** -len(text.split(".")[1]) if "." in text else 0.5


def test_a_zero_dragged_with_the_mouse_moves_the_margins(workdir):
    """The lead's zero dragged on the pole map by SGR mouse reports (press, three moves, release):
    the tableau's margins are python-control's of the design, and the undo key pressed once
    brings back the start's (python-control's of T1 = 1): the drag was one undo step."""
    import control as ct

    from tui.cli import main

    path = workdir / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    session = f"loopcraft-e2e-{time.monotonic_ns()}"
    python_path = f"PYTHONPATH={os.environ['PYTHONPATH']} " if os.environ.get("PYTHONPATH") else ""
    command = (
        f"cd {workdir} && LOOPCRAFT_HOME={workdir / 'home'} TERM=xterm-256color {python_path}{LOOPCRAFT} lead.json"
    )
    start(session, 120, 40, command)
    try:
        wait_for(session, "Iteration 0", "PM deg")
        for _ in range(4):  # Nyquist, Bode, Nichols, S/T, Poles
            tmux("send-keys", "-t", session, "p")
        screen = wait_for(session, "Poles and zeros", "compensator zeros")
        rows = screen.splitlines()
        (row,) = [k for k, line in enumerate(rows) if "0┤" in line and "z" in line.split("0┤", 1)[1]]
        col = rows[row].index("z", rows[row].index("0┤"))
        _sgr(session, 0, col + 1, row + 1)
        for step in (1, 2, 3):  # three columns left: the zero at a higher frequency
            _sgr(session, 32, col + 1 - step, row + 1)
        _sgr(session, 0, col + 1 - 3, row + 1, release=True)
        screen = wait_for(session, "edit: T1 value: 1 ->")
        tmux("send-keys", "-t", session, "C-s")
        screen = wait_for(session, "saved")
        values = {p["name"]: p["value"] for p in json.loads(path.read_text())["problem"]["parameters"]}
        assert values["T1"] < 1 and values["K"] == 1 and values["T2"] == 0.1
        loop = ct.tf([values["T1"], 1], [values["T2"], 1]) * ct.tf([1], [1, 10, 0, 0])
        gm, pm, _, _, _, _ = ct.stability_margins(loop)
        shown_pm, shown_gm = _shown_number(screen, "PM deg"), _shown_number(screen, "GM dB")
        assert abs(float(shown_pm) - pm) <= _half_digit(shown_pm)
        assert abs(float(shown_gm) - 20 * math.log10(gm)) <= _half_digit(shown_gm)

        # one undo step: ctrl+z pressed once brings back the start's margins (T1 = 1)
        gm, pm, _, _, _, _ = ct.stability_margins(ct.tf([1, 1], [0.1, 1]) * ct.tf([1], [1, 10, 0, 0]))
        tmux("send-keys", "-t", session, "C-z")
        screens = [wait_for(session, "PM deg", "GM dB")]

        def at_start() -> bool:
            screens[0] = tmux("capture-pane", "-t", session, "-p")
            shown = _shown_number(screens[0], "PM deg"), _shown_number(screens[0], "GM dB")
            return abs(float(shown[0]) - pm) <= _half_digit(shown[0]) and abs(
                float(shown[1]) - 20 * math.log10(gm)
            ) <= _half_digit(shown[1])

        wait_until(at_start, lambda: f"the start's margins never came back; the screen:\n{screens[0]}")
        assert "undid: T1 value: 1 -> " in screens[0].splitlines()[0]  # the whole drag's edit, from the start's T1
    finally:
        tmux("kill-session", "-t", session)

"""Snapshots of every screen with a bundled example, at 120x40, 100x32 and 80x24
(`pytest --snapshot-update` accepts changes after looking at them)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from textual.app import App, ComposeResult

from sessions.store import load_session
from tests.tui.test_tolerance_study import studied
from tui.app import LoopcraftApp
from tui.figures.trajectories import trajectories_figure
from tui.state.workbench import Workbench
from tui.widgets.plots import FigurePlot

# 80x24, the tightest, in `make test`; 120x40 and 100x32 in the long tier
SIZES = [pytest.param((120, 40), marks=pytest.mark.long), pytest.param((100, 32), marks=pytest.mark.long), (80, 24)]


def steps(*keys: str, wait_workers: bool = True):
    async def run_before(pilot) -> None:
        await pilot.pause()
        await pilot.app.workers.wait_for_complete()  # the plots are drawn in a worker
        await pilot.pause()
        for key in keys:
            await pilot.press(key)
            await pilot.pause()
            if wait_workers:
                await pilot.app.workers.wait_for_complete()
                await pilot.pause()
        # a toast lives for seconds of wall time: shown or gone by the snapshot depending on the
        # machine's load (a loaded run lost "iteration 1 marked" and failed), so none is kept
        pilot.app.clear_notifications()
        await pilot.pause()

    return run_before


CASES = {
    "start": (None, steps()),
    "run_initial": ("cip_launch_vehicle.json", steps()),
    "run_after_steps": ("cip_launch_vehicle.json", steps("s", "s")),
    "bode": ("cip_launch_vehicle.json", steps("s", "p")),  # p: the next plot, the Bode plot
    "plant": ("cip_launch_vehicle.json", steps("2")),
    "targets": ("cip_dual_channel.json", steps("3")),
    "history": ("cip_launch_vehicle.json", steps("s", "s", "s", "4")),
    # History's views of iteration 1 (beside the current design), or of iteration 3 against the marked 1
    "history_closed_loop": ("lead_sensitivity_peak.json", steps("s", "s", "s", "4", "down", *"pppp")),
    "history_nichols_marked": (
        "lead_sensitivity_peak.json",
        steps("s", "s", "s", "4", "down", "m", "down", "down", *"ppp"),
    ),
    "history_poles_marked": (
        "lead_sensitivity_peak.json",
        steps("s", "s", "s", "4", "down", "m", "down", "down", *"ppppp"),
    ),
    "history_locus": ("lead_sensitivity_peak.json", steps("s", "s", "s", "4", "down", *"pppppp")),
    "help": ("cip_launch_vehicle.json", steps("question_mark")),
    "qcg_run": ("seidel_inlet_pi.json", steps("s", "s", "s")),
    "closed_loop": ("report003_lag_lead.json", steps("p", "p", "p")),
    "poles": ("report003_lag_lead.json", steps("p", "p", "p", "p")),
    "locus": ("report003_lag_lead.json", steps("p", "p", "p", "p", "p")),
    "matrix_grid": ("coebra_launch_vehicle_matrix.json", steps("2")),
}


@pytest.mark.parametrize("size", SIZES, ids=["120x40", "100x32", "80x24"])
@pytest.mark.parametrize("case", list(CASES))
def test_screen(case, size, workdir, snap_compare):
    name, run_before = CASES[case]
    app = LoopcraftApp(workdir / name if name else None)
    assert snap_compare(app, terminal_size=size, run_before=run_before)


async def scrolled_right(pilot) -> None:
    """The Sweep tab, its table scrolled by the right key to its last columns."""
    await steps("5")(pilot)
    table = pilot.app.screen.query_one("#optima-table")
    assert table.has_focus and table.max_scroll_x > 0
    while table.scroll_x < table.max_scroll_x:
        await pilot.press("right")
        await pilot.wait_for_scheduled_animations()
        await pilot.pause()


SWEEP_CASES = {
    "120x40": ((120, 40), steps("5")),
    "80x24": ((80, 24), steps("5")),
    "80x24-right": ((80, 24), scrolled_right),
}


@pytest.mark.long  # a tolerance study of 30 samples first
@pytest.mark.parametrize("case", list(SWEEP_CASES))
def test_sweep_tab(case, workdir, snap_compare, capsys):
    """The Sweep tab after the lag-lead's tolerance study: the histogram of the first row beside
    the table, whose percentile and worst-sample columns scroll (a scroll bar under them; the right
    key shows them)."""
    size, run_before = SWEEP_CASES[case]
    path = studied(workdir)
    capsys.readouterr()
    session = json.loads(Path(path).read_text())
    session["sweeps"][-1]["created"] = "2026-01-02T03:04:05+00:00"  # the study's time, the same each run
    Path(path).write_text(json.dumps(session))
    assert snap_compare(LoopcraftApp(path), terminal_size=size, run_before=run_before)


class PlotApp(App):
    """One plot filling the screen (the Trajectories pane's size), showing a figure."""

    def __init__(self, figure):
        super().__init__()
        self.figure = figure

    def compose(self) -> ComposeResult:
        yield FigurePlot(id="trajectories")

    def on_mount(self) -> None:
        self.query_one(FigurePlot).show(self.figure)


@pytest.mark.parametrize("size", [(72, 34), (48, 18)], ids=lambda s: f"{s[0]}x{s[1]}")
def test_reactor_trajectories(size, workdir, snap_compare):
    """Report 004's reactor after 3 iterations (converged), at the Trajectories pane's size in a
    120x40 and an 80x24 terminal: u2, its bound and the open loop over the trims u6, u7.  The
    workbench draws it from the presenter's trajectories and the system's data."""
    bench = Workbench(load_session(workdir / "projection_reactor.json"))
    for _ in range(3):
        bench.step()
    figure = trajectories_figure(bench.view().trajectories(), bench.session.problem.objective.data)
    assert snap_compare(PlotApp(figure), terminal_size=size, run_before=steps())


# the break selector (issue 57): the launch vehicle's loops at u_att (b), its tableau's lines of
# every break and the multi-loop disk margin; 80x24 in `make test`, 120x40 in the long tier
BREAK_CASES = {
    "break_nyquist": ("coebra_launch_vehicle.json", steps("b")),
    "break_bode": ("coebra_launch_vehicle.json", steps("p", "b")),
    "break_tableau": ("coebra_launch_vehicle.json", steps("b", "1", "end")),  # the lines of every break
}


@pytest.mark.parametrize("size", [(80, 24), pytest.param((120, 40), marks=pytest.mark.long)], ids=["80x24", "120x40"])
@pytest.mark.parametrize("case", list(BREAK_CASES))
def test_break_screen(case, size, workdir, snap_compare):
    name, run_before = BREAK_CASES[case]
    assert snap_compare(LoopcraftApp(workdir / name), terminal_size=size, run_before=run_before)

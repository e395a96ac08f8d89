"""Every plot shows the current design after any change of it (issue 36, section 3): each
path compares what the plots on screen show (their figures' series and legends) with
fresh figures of the current view."""

from __future__ import annotations

import pytest

from tests.tui.test_app import edit_row, select_row, settle, synchronous
from tui.app import LoopcraftApp
from tui.figures.catalog import FIGURE_IDS, figures
from tui.widgets.plots import FigurePlot


def _drawn(figure) -> list:
    """What a figure shows: its title and each series' label and points (panels too)."""
    parts = [figure.title, [(s.label, s.x, s.y) for s in figure.series]]
    return parts + [_drawn(panel) for panel in figure.panels]


async def stale_plots(app, pilot) -> list[str]:
    """The plots of the run tab, each shown in turn, whose figure is not the current view's."""
    await pilot.press("1")
    await settle(app, pilot)
    stale = []
    for tab in app.screen.plot_tabs:
        app.screen.query_one("#plots").active = tab
        await settle(app, pilot)
        view = app.bench.view()
        for plot in app.screen.query(FigurePlot):
            if plot.id in FIGURE_IDS and plot.display and plot.region.width > 0:
                fresh = figures(view, {plot.id})[plot.id]
                if _drawn(plot.figure) != _drawn(fresh):
                    stale.append(plot.id)
    return stale


@pytest.mark.long
@synchronous
async def test_a_run_finished_on_another_tab_shows_on_every_plot(workdir):
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("3")
        await pilot.press("r")
        await settle(app, pilot)
        assert app.bench.iteration > 0
        assert await stale_plots(app, pilot) == []


@pytest.mark.long
@synchronous
async def test_undo_and_redo_of_iterations_show_on_every_plot(workdir):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        for key in ("s", "s", "s"):
            await pilot.press(key)
            await settle(app, pilot)
        assert app.bench.iteration == 3
        await pilot.press("2")  # undo on another tab, then come back
        await pilot.press("z")
        await settle(app, pilot)
        assert app.bench.iteration == 2 and await stale_plots(app, pilot) == []
        await pilot.press("Z")  # redo on the run tab itself
        await settle(app, pilot)
        assert app.bench.iteration == 3 and await stale_plots(app, pilot) == []


@pytest.mark.long
@synchronous
async def test_an_edit_and_its_undo_show_on_every_plot(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        await edit_row(app, pilot, "2", "blocks", 0)
        app.screen.query_one("#value").value = "(s+z1)*(s+z2)/((s+p1)*(s+p2))*2"
        await pilot.press("enter")
        await pilot.pause()
        await pilot.press("y")  # the recorded iteration will be dropped: yes
        await settle(app, pilot)
        assert await stale_plots(app, pilot) == []
        await pilot.press("ctrl+z")
        await settle(app, pilot)
        assert app.bench.iteration == 1 and await stale_plots(app, pilot) == []


@pytest.mark.long
@synchronous
async def test_starting_again_from_an_earlier_iteration_shows_on_every_plot(workdir):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        for _ in range(3):
            await pilot.press("s")
            await settle(app, pilot)
        assert app.bench.iteration == 3
        await select_row(app, pilot, "4", "history-table", 1)
        await pilot.press("enter")  # start again from here
        await pilot.pause()
        await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.iteration == 1 and await stale_plots(app, pilot) == []


@pytest.mark.long
@synchronous
async def test_each_flight_condition_shows_on_every_plot(workdir):
    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        for _ in range(4):  # each condition alone, then all of them again
            await pilot.press("v")
            await settle(app, pilot)
            assert await stale_plots(app, pilot) == []


def test_a_figure_key_is_never_matched_by_a_later_object_at_a_freed_address():
    """The key held ids: an edited problem freed, a new one could take its address and
    the plots of the old design pass for current.  CPython gives a new object of one size
    the freed block at once, so an id key matched here on the first try."""
    from types import SimpleNamespace

    from tui.figures.catalog import figure_key

    class Problem:
        pass

    def view(problem):
        return SimpleNamespace(
            problem=problem,
            records=(),
            iteration=0,
            plotted_condition=None,
            step_setup=None,
            sweep=None,
            plotted_break=None,
        )

    kept = figure_key(view(Problem()))
    assert all(figure_key(view(Problem())) != kept for _ in range(200))


def test_the_noise_notes_are_those_of_the_record_asked_about(monkeypatch):
    """Kept by (problem id, iteration): an undone finished iteration's notes were shown for
    the different design stepped to the same iteration after it."""
    from dataclasses import replace
    from pathlib import Path

    import tui.state.workbench as workbench
    from engine.stepping.protocol import Status
    from sessions.store import load_session
    from tui.state.workbench import Workbench

    monkeypatch.setattr(workbench, "noise_notes", lambda problem, values: [f"noise of {sorted(values.items())[0]}"])
    path = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "lead_sensitivity_peak.json"
    bench = Workbench(load_session(path))
    bench.session.path = None
    bench.step()
    first = replace(bench.records[-1], status=Status.CONVERGED)
    second = replace(first, parameters={name: 2 * value for name, value in first.parameters.items()})
    assert bench.design_notes(first) != bench.design_notes(second)

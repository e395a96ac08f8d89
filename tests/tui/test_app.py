"""Pilot tests of the workbench's behaviour."""

from __future__ import annotations

import asyncio
import functools
import json
import time

import pytest

from engine.errors import EngineError
from tui.app import LoopcraftApp
from tui.screens.main import MainScreen
from tui.state.field_edits import objective_rows


def synchronous(test):
    """Run an async test on a fresh event loop (no async plugin needed)."""

    @functools.wraps(test)
    def run(*args, **kwargs):
        return asyncio.run(test(*args, **kwargs))

    return run


def status(app) -> str:
    return str(app.screen.query_one("#status").render())


async def select_row(app, pilot, tab: str, table: str, row: int) -> None:
    """Show a tab (its number key), focus one of its tables and put the cursor on a row."""
    await pilot.press(tab)
    widget = app.screen.query_one(f"#{table}")
    widget.focus()
    widget.move_cursor(row=row)


async def edit_row(app, pilot, tab: str, table: str, row: int) -> None:
    """Select a row (`select_row`) and open its edit dialog (e)."""
    await select_row(app, pilot, tab, table, row)
    await pilot.press("e")
    await pilot.pause()


async def typo_then_enter(app, pilot, typo: str, message: str, good: str) -> None:
    """In the open edit dialog: type a typo, see the dialog name the problem, type
    the good value and press enter (the dialog stays open until the value is good)."""
    field = app.screen.query_one("#value")
    field.value = typo
    await pilot.pause()
    assert message in str(app.screen.query_one("#error").render())
    field.value = good
    await pilot.press("enter")


async def settle(app, pilot) -> None:
    await pilot.pause()
    await app.workers.wait_for_complete()
    await pilot.pause()


@synchronous
async def test_stepping_updates_the_tableau_and_the_iteration(workdir):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert "Iteration 0" in status(app)
        tableau = app.screen.query_one("#tableau")
        before = str(tableau.render())
        for _ in range(3):
            await pilot.press("s")
            await settle(app, pilot)
        assert "Iteration 3" in status(app)
        assert str(tableau.render()) != before and "NO" in before
        assert len(app.bench.session.model.records) == 3


@synchronous
async def test_pause_stops_a_run_within_one_iteration(workdir, monkeypatch):
    app = LoopcraftApp(workdir / "cip_dual_channel.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        stepper = type(app.bench.ensure_stepper())  # a bound stepper is frozen: its class is patched
        step = stepper.step

        def slow_step(self, state):  # an algorithm whose iterations take 20 ms, so the run is still going
            time.sleep(0.02)
            return step(self, state)

        monkeypatch.setattr(stepper, "step", slow_step)
        await pilot.press("r")
        await pilot.pause(0.3)
        await pilot.press("space")
        await settle(app, pilot)
        stopped = app.bench.iteration
        await pilot.pause(0.3)
        assert app.bench.iteration == stopped and 0 < stopped < 111
        assert not app.bench.status().finished


@pytest.mark.long
@synchronous
async def test_undo_and_start_from_an_earlier_iteration(workdir):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        for _ in range(3):
            await pilot.press("s")
            await settle(app, pilot)
        await pilot.press("z")
        await settle(app, pilot)
        assert app.bench.iteration == 2 and "Iteration 2" in status(app)
        await select_row(app, pilot, "4", "history-table", 1)
        await settle(app, pilot)  # the History plot is drawn by a worker
        history_plot = app.screen.query_one("#history-plot").figure
        assert history_plot.title == "Nyquist: iteration 1"
        curves = [s for s in history_plot.series if s.label][:2]  # the unlabelled: unit circle, mirror images
        assert [s.label for s in curves] == ["iteration 1", "current"]
        assert curves[0].y != curves[1].y
        await pilot.press("enter")  # start again from here
        await pilot.pause()
        await pilot.press("y")  # later iterations will be dropped: yes
        await settle(app, pilot)
        assert app.bench.iteration == 1
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 2


@synchronous
async def test_save_and_reopen_gives_the_same_session(workdir):
    path = workdir / "seidel_inlet_pi.json"
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        for _ in range(2):
            await pilot.press("s")
            await settle(app, pilot)
        await pilot.press("ctrl+s")
        await settle(app, pilot)
        saved = json.loads(path.read_text())
        assert not app.bench.dirty
    again = LoopcraftApp(path)
    async with again.run_test(size=(120, 40)) as pilot:
        await settle(again, pilot)
        assert again.bench.session.model.records == saved["records"]
        assert "Iteration 2" in status(again)


@synchronous
async def test_an_engine_error_is_a_notification_not_a_crash(workdir, monkeypatch):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)

        def broken(self, state):
            raise EngineError("singular matrix at 3.1 rad/s")

        monkeypatch.setattr(type(app.bench.ensure_stepper()), "step", broken)
        await pilot.press("s")
        await settle(app, pilot)
        assert any("singular matrix" in n.message for n in app._notifications)
        assert isinstance(app.screen, MainScreen) and app.is_running


@synchronous
async def test_a_typo_in_an_expression_is_shown_and_the_old_value_kept(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await edit_row(app, pilot, "2", "blocks", 0)
        dialog = app.screen
        field = dialog.query_one("#value")
        field.value = "(s+z1)*(s+z2)/((s+p1)*(s+p2"
        await pilot.pause()
        assert "column" in str(dialog.query_one("#error").render())
        await pilot.press("enter")  # refused: still the dialog
        await pilot.pause()
        assert app.screen is dialog
        await pilot.press("escape")
        await pilot.pause()
        block = app.bench.session.model.problem.conditions[0].plant.blocks[0]
        assert block.transfer.expression == "(s+z1)*(s+z2)/((s+p1)*(s+p2))"


@synchronous
async def test_start_screen_opens_an_example(workdir, monkeypatch):
    app = LoopcraftApp()
    async with app.run_test(size=(100, 32)) as pilot:
        await pilot.pause()
        await pilot.press("enter")
        await settle(app, pilot)
        assert isinstance(app.screen, MainScreen)
        assert app.bench.session.path.parent == workdir / "home" / "examples"


@synchronous
async def test_a_bad_session_file_is_a_message_and_the_start_screen(workdir):
    bad = workdir / "broken.json"
    bad.write_text('{"schema_version": 1, "problem": ')
    app = LoopcraftApp(bad)
    async with app.run_test(size=(100, 32)) as pilot:
        await pilot.pause()
        assert any("line 1" in n.message for n in app._notifications)
        assert type(app.screen).__name__ == "StartScreen" and app.is_running
    assert bad.read_text() == '{"schema_version": 1, "problem": '  # left untouched


@synchronous
async def test_editing_a_targets_bands(workdir):
    app = LoopcraftApp(workdir / "cip_dual_channel.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await edit_row(app, pilot, "3", "targets-table", 2)  # stability margins, desired 0.49
        await pilot.press("enter")  # "bands", the first choice
        await pilot.pause()
        field = app.screen.query_one("#value")
        assert field.value == "0..inf: 0.49"
        await typo_then_enter(
            app,
            pilot,
            "0..1: 0.5; 1..inf 0.4",
            "write LOW..HIGH: DESIRED",  # the missing colon
            "0..1: 0.5; 1..inf: 0.4",
        )
        await settle(app, pilot)
        bands = app.bench.session.problem.targets[2].bands
        assert [(b.low, b.desired) for b in bands] == [(0.0, 0.5), (1.0, 0.4)]


@synchronous
async def test_editing_a_parameter_bound(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await edit_row(app, pilot, "2", "parameters", 0)  # z1
        await pilot.press("down", "enter")  # "min"
        await pilot.pause()
        field = app.screen.query_one("#value")
        assert field.value == "0.01"
        field.value = "0.5"
        await pilot.press("enter")
        await settle(app, pilot)
        assert app.bench.session.problem.parameters[0].minimum == 0.5


@synchronous
async def test_importing_a_csv_table_into_a_block_with_a_preview(workdir):
    (workdir / "plant.csv").write_text("# measured\nhz,mag,deg\n0.01,100,-90\n1,1,-120\n100,0.001,-180\n")
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await select_row(app, pilot, "2", "blocks", 1)  # the plant block
        await pilot.press("i")
        await pilot.pause()
        app.screen.query_one("#value").value = "plant.csv"
        await pilot.press("enter")
        await pilot.pause()
        assert "0.01,100,-90" in str(app.screen.query_one("Label").render())  # the preview
        field = app.screen.query_one("#value")
        assert field.value == "hz,mag,deg polar hz 1"
        await typo_then_enter(app, pilot, "hz,mag,phase polar hz 1", "no column 'phase'", "hz,mag,deg polar hz 1")
        await settle(app, pilot)
        transfer = app.bench.session.model.problem.conditions[0].plant.blocks[1].transfer
        assert transfer.kind == "table" and transfer.table.csv == "plant.csv"
        assert not app.bench.session.problem.conditions[0].network.exact


@synchronous
async def test_a_setting_is_checked_against_the_algorithm(workdir):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        labels = [label for label, _, _ in objective_rows(app.bench)]
        await edit_row(app, pilot, "3", "objective-table", labels.index("cip.mode"))
        await typo_then_enter(app, pilot, "fastest", "tifr", "sifr")
        await settle(app, pilot)
        assert app.bench.session.model.algorithm.settings["mode"] == "sifr"


@pytest.mark.long
@synchronous
async def test_an_slp_session_steps_and_edits_a_requirement(workdir):
    """slp on the launch vehicle: a trial per step, the tableau over three
    conditions, and a band edited with its requirement ('desired / required')."""
    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        assert "Iteration 1" in status(app)
        tableau = str(app.screen.query_one("#tableau").render())
        assert "max-q" in tableau and "switch-out" in tableau
        record = app.bench.records[-1]
        assert record.extra["major"] == 1 and record.extra["minor"] == 1
        await edit_row(app, pilot, "3", "targets-table", 2)  # phase margin: 0.5..8: 40 / 30
        await pilot.press("enter")
        await pilot.pause()
        field = app.screen.query_one("#value")
        assert field.value == "0.5..8: 40 / 30"
        field.value = "0.5..8: 45 / 35"
        await pilot.press("enter")
        await pilot.pause()
        await pilot.press("y")  # the recorded iteration will be dropped: yes
        await settle(app, pilot)
        band = app.bench.session.problem.targets[2].bands[0]
        assert (band.desired, band.required) == (45.0, 35.0)
        assert app.bench.iteration == 0  # the problem changed: the records are gone


@pytest.mark.long
@synchronous
async def test_a_sweep_runs_on_a_local_cluster_and_its_best_design_is_used(workdir):
    """w: a multi-start sweep on Dask from the workbench; the Sweep tab shows its
    optima; u makes the best one the start."""
    app = LoopcraftApp(workdir / "coebra_kuo_digital.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("w")
        await pilot.pause()
        await typo_then_enter(app, pilot, "starts 4 seed 2 at", "needs a scheduler address", "starts 4 seed 2")
        deadline = time.monotonic() + 120
        while app.bench.sweeps.latest() is None and time.monotonic() < deadline:
            await pilot.pause(0.2)
        sweep = app.bench.sweeps.latest()
        assert sweep is not None and len(sweep["runs"]) == 4 and sweep["workers"] >= 1
        table = app.screen.query_one("#optima-table")
        assert table.row_count == len(sweep["optima"]) >= 1
        assert "starts sweep" in str(app.screen.query_one("#sweep-status").render())
        await pilot.press("u")
        await settle(app, pilot)
        best = sweep["runs"][sweep["optima"][0]["best_run"]]["parameters"]
        assert app.bench.session.problem.condition_values(0)["T1"] == best["T1"]
        from tests.tui.test_never_stale import stale_plots

        assert await stale_plots(app, pilot) == []  # every plot shows the adopted design


@pytest.mark.long
@synchronous
async def test_targets_parameters_blocks_and_options_are_added_deleted_and_edited(workdir):
    """Nothing requires editing JSON: + adds a target (by measure), a parameter or a
    block, - deletes the selected one, an objective option (a penalty) is edited."""
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        problem = lambda: app.bench.session.model.problem  # noqa: E731
        count = len(problem().targets)
        await select_row(app, pilot, "3", "targets-table", 0)
        await pilot.press("plus")
        await pilot.pause()
        for _ in range(6):  # crossover_frequency, the 7th measure
            await pilot.press("down")
        await pilot.press("enter")
        await settle(app, pilot)
        assert [t.measure for t in problem().targets][-1] == "crossover_frequency"
        assert app.screen.query_one("#targets-table").row_count == count + 1
        await select_row(app, pilot, "3", "targets-table", count)
        await pilot.press("minus")
        await pilot.pause()
        await pilot.press("y")
        await settle(app, pilot)
        assert len(problem().targets) == count
        await select_row(app, pilot, "2", "parameters", 0)
        await pilot.press("plus")
        await pilot.pause()
        app.screen.query_one("#value").value = "Kf 2 0 10"
        await pilot.press("enter")
        await settle(app, pilot)
        await select_row(app, pilot, "2", "blocks", 0)
        await pilot.press("plus")
        await pilot.pause()
        await typo_then_enter(app, pilot, "filter y ym", "NAME INPUT OUTPUT EXPRESSION", "filter y ym Kf/(1+0.01*s)")
        await settle(app, pilot)
        assert problem().parameters[-1].name == "Kf" and problem().conditions[0].plant.blocks[-1].name == "filter"
        assert "Kf" in app.bench.session.problem.conditions[0].network.parameters


@synchronous
async def test_an_objective_penalty_and_an_unset_setting_are_edited(workdir):
    app = LoopcraftApp(workdir / "seidel_inlet_pi.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        labels = [label for label, _, _ in objective_rows(app.bench)]
        q2 = labels.index("q2")
        await edit_row(app, pilot, "3", "objective-table", q2)
        app.screen.query_one("#value").value = "0.001"
        await pilot.press("enter")
        await settle(app, pilot)
        assert app.bench.session.model.problem.objective.options["q2"] == 0.001
        assert app.bench.session.problem.objective.options["q2"] == 0.001
        row = next(k for k, label in enumerate(labels) if label.startswith("qcg.") and "(default)" in label)
        await edit_row(app, pilot, "3", "objective-table", row)
        assert app.screen.query_one("#value").value != ""  # the default is shown


@synchronous
async def test_v_cycles_the_plots_through_the_flight_conditions(workdir):
    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        nyquist = app.screen.query_one("#nyquist")
        names = [c.name for c in app.bench.session.problem.conditions]

        def labels() -> list[str]:  # the curves' (the unit circle and the mirror images have none)
            return [s.label for s in nyquist.figure.series if s.label][:3]

        assert labels() == names
        await pilot.press("v")
        await pilot.pause()
        assert any(f"plots: {names[0]}" in str(n.message) for n in app._notifications)
        assert labels()[0] == f"{names[0]}: current"
        for _ in names:
            await pilot.press("v")
        await pilot.pause()
        assert labels() == names


@pytest.mark.parametrize(("size", "hinted"), [((80, 24), False), ((120, 40), True)])
@synchronous
async def test_the_status_line_keeps_the_state_whole_at_80_columns(workdir, size, hinted):
    """At 80 columns the status line ('cip_launch_vehicle.json *  algorithm cip  Iteration 1
    not finished (s steps on, r runs on)', 91 cells) was cut in the middle of its hint; where it
    does not fit, the word 'algorithm' and the keys the footer shows go, and the state is whole;
    where it fits, all of it."""
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=size) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        status = app.screen.query_one("#status")
        shown = status.text.plain
        assert "Iteration 1" in shown and "not finished" in shown, shown
        assert ("(s steps on, r runs on)" in shown and "algorithm cip" in shown) == hinted, shown
        assert len(shown) <= status.content_size.width, shown


@synchronous
async def test_the_status_line_follows_a_resize(workdir):
    """The status line's form is chosen again when the terminal is resized: 120 columns to 80
    (short: whole), and back (the hints again)."""
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        status = app.screen.query_one("#status")
        for size, hinted in (((80, 24), False), ((120, 40), True)):
            await pilot.resize_terminal(*size)
            await settle(app, pilot)
            shown = status.text.plain
            assert ("(s steps on, r runs on)" in shown) == hinted and len(shown) <= status.content_size.width, shown

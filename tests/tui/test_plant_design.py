"""The Plant tab shows the current design beside the start, and one key adopts it."""

from __future__ import annotations

from engine.stepping.presenter import number
from tests.tui.test_app import select_row, settle, synchronous
from tui.app import LoopcraftApp


@synchronous
async def test_the_parameters_show_the_current_design_and_d_makes_it_the_start(workdir):
    app = LoopcraftApp(workdir / "seidel_inlet_pi.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        start = {p.name: p.value for p in app.bench.session.model.problem.parameters}
        for _ in range(3):
            await pilot.press("s")
            await settle(app, pilot)
        current = app.bench.records[-1].parameters
        await select_row(app, pilot, "2", "parameters", 0)
        table = app.screen.query_one("#parameters")
        name = str(table.get_row_at(0)[0])
        assert str(table.get_row_at(0)[1]) == number(current[name]) != number(start[name])
        assert str(table.get_row_at(0)[2]) == number(start[name])
        await pilot.press("d")
        await pilot.pause()
        await pilot.press("y")  # the three iterations will be dropped: yes
        await settle(app, pilot)
        assert app.bench.iteration == 0
        assert app.bench.session.model.problem.parameters[0].value == current[name]
        assert str(table.get_row_at(0)[1]) == number(current[name])
        assert app.check_action("adopt_design", ()) is None  # nothing to adopt at iteration 0: disabled
        assert app.disabled_reason("adopt_design") == "no iteration yet: the start is the current design"
        await pilot.press("d")  # pressed anyway: it says why, and nothing changes
        await settle(app, pilot)
        assert any("no iteration yet" in n.message for n in app._notifications)
        assert app.bench.iteration == 0
        # the footer's disabled key says the same as its tooltip (issue 37, section 7)
        keys = [k for k in app.screen.query(".-disabled") if getattr(k, "action", None) == "undo"]
        assert keys and all(str(k.tooltip).endswith(": no iteration to drop") for k in keys)


@synchronous
async def test_d_acts_from_any_tab_and_l_on_a_tabulated_loop_says_why(workdir):
    """Issue 37 section 7: 'd' needed the parameter table's focus; 'L' did nothing silently."""
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")  # a tabulated plant: no root locus
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        await pilot.press("L")
        await settle(app, pilot)
        assert any("no root locus here" in n.message for n in app._notifications)
        await pilot.press("d")  # from the Run tab
        await pilot.pause()
        await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.iteration == 0

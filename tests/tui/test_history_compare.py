"""History: m marks an iteration, the others are compared with it (measures side by
side, curves overlaid as Nyquist, Bode or step)."""

from __future__ import annotations

from tui.app import LoopcraftApp

from .test_app import select_row, settle, synchronous


@synchronous
async def test_two_iterations_are_compared_and_their_curves_overlaid(workdir):
    app = LoopcraftApp(workdir / "coebra_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        for _ in range(3):
            await pilot.press("s")
            await settle(app, pilot)
        await select_row(app, pilot, "4", "history-table", 0)
        await pilot.press("m")
        await pilot.pause()
        table = app.screen.query_one("#history-table")
        table.move_cursor(row=3)
        await pilot.pause()
        text = app.screen.query_one("#history-tableau").text.plain
        assert "iteration 0" in text and "iteration 3" in text
        figure = app.screen.query_one("#history-plot").figure
        assert figure.title == "Nyquist: iteration 3 against start"
        assert [s.label for s in figure.series if s.label][:2] == ["iteration 3", "start (marked)"]
        await pilot.press("o")
        await pilot.pause()
        assert app.screen.query_one("#history-plot").figure.title.startswith("Bode magnitude: iteration 3")
        await pilot.press("o")
        await pilot.pause()
        step = app.screen.query_one("#history-plot").figure
        assert step.title.startswith("Step: iteration 3") and len([s for s in step.series if s.label]) >= 2
        await pilot.press("m")            # m on another row marks that one instead
        await pilot.pause()
        assert app.screen.compare_mark == 3

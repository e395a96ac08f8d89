"""History: m marks an iteration, the others are compared with it (measures side by
side, curves overlaid; o or p chooses the view)."""

from __future__ import annotations

import pytest

from tests.tui.test_app import select_row, settle, synchronous
from tui.app import LoopcraftApp


@pytest.mark.long
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
        await settle(app, pilot)
        table = app.screen.query_one("#history-table")
        table.move_cursor(row=3)
        await settle(app, pilot)
        text = app.screen.query_one("#history-tableau").text.plain
        assert "iteration 0" in text and "iteration 3" in text
        figure = app.screen.query_one("#history-plot").figure
        assert figure.title == "Nyquist: iteration 3 vs marked start"
        assert [s.label for s in figure.series if s.label][:2] == ["iteration 3", "start (marked)"]
        await pilot.press("o")
        await settle(app, pilot)
        assert app.screen.query_one("#history-plot").figure.title.startswith("Bode magnitude: iteration 3")
        for _ in range(6):  # phase, Nichols, S/T, poles, locus: step
            await pilot.press("o")
            await settle(app, pilot)
        step = app.screen.query_one("#history-plot").figure
        assert step.title.startswith("Step: iteration 3") and len([s for s in step.series if s.label]) >= 2
        await pilot.press("m")  # m on another row marks that one instead
        await pilot.pause()
        assert app.screen.query_one("#history-pane").compare_mark == 3

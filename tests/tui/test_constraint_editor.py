"""Linear constraints between parameters are added, edited and deleted in the Targets tab."""

from __future__ import annotations

import pytest

from tests.tui.test_app import select_row, settle, synchronous
from tui.app import LoopcraftApp
from tui.state.field_edits import objective_rows


@pytest.mark.long
@synchronous
async def test_a_constraint_is_added_checked_edited_and_deleted(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await select_row(app, pilot, "3", "objective-table", 0)
        await pilot.press("plus")
        await pilot.pause()
        field = app.screen.query_one("#value")
        field.value = "z1*p1 <= 3"
        await pilot.pause()
        assert "z1" in str(app.screen.query_one("#error").render())  # not linear: said while typing
        field.value = "p2 >= 10*p1"
        await pilot.press("enter")
        await settle(app, pilot)
        assert app.bench.session.model.problem.constraints == ["p2 >= 10*p1"]
        assert app.bench.session.problem.linear_constraints is not None
        row = next(k for k, (label, _, _) in enumerate(objective_rows(app.bench)) if label == "constraint 1")
        await select_row(app, pilot, "3", "objective-table", row)
        await pilot.press("e")
        await pilot.pause()
        app.screen.query_one("#value").value = "p2 >= 1000*p1"  # not met at the start: refused
        await pilot.pause()
        assert "not met" in str(app.screen.query_one("#error").render())
        app.screen.query_one("#value").value = "p2 >= 100*p1"
        await pilot.press("enter")
        await settle(app, pilot)
        assert app.bench.session.model.problem.constraints == ["p2 >= 100*p1"]
        await pilot.press("minus")
        await pilot.pause()
        await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.session.model.problem.constraints == []

"""The tab keys 1-5 work from every widget, and each tab focuses its main widget."""

from __future__ import annotations

from tests.tui.test_app import synchronous
from tui.app import LoopcraftApp
from tui.screens.main import MAIN_WIDGETS

TABS = {"1": "run", "2": "plant", "3": "targets", "4": "history", "5": "sweep"}


@synchronous
async def test_every_tab_key_works_from_every_table_and_focuses_the_tab(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        tabs = app.screen.query_one("#tabs")
        starts = {
            "blocks": "2",
            "parameters": "2",
            "targets-table": "3",
            "objective-table": "3",
            "history-table": "4",
            "optima-table": "5",
        }
        for n, (start, home) in enumerate(starts.items()):
            for key in (str(n % 5 + 1), str((n + 2) % 5 + 1)):  # every tab key, from two tables each
                pane = TABS[key]
                widget = app.screen.query_one(f"#{start}")
                await pilot.press(home)
                widget.focus()
                await pilot.pause()
                assert app.focused is widget
                await pilot.press(key)
                await pilot.pause()
                assert tabs.active == pane, (start, key, tabs.active)
                assert app.focused is app.screen.query_one(MAIN_WIDGETS[pane]), (start, key, app.focused)


@synchronous
async def test_tab_and_shift_tab_leave_a_table(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        await pilot.press("2")
        seen = set()
        for key in ["tab"] * 4 + ["shift+tab"] * 4:
            await pilot.press(key)
            await pilot.pause()
            seen.add(type(app.focused).__name__)
        assert {"PlantTable", "ParametersTable"} <= seen and len(seen) > 2, seen
        await pilot.press("3")
        await pilot.pause()
        assert app.screen.query_one("#tabs").active == "targets"

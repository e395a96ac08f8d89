"""The tab keys 1-5 work from every widget, and each tab focuses its main widget."""

from __future__ import annotations

import pytest

from tests.tui.test_app import settle, synchronous
from tests.tui.test_shape_table import lead_app
from tui.app import LoopcraftApp
from tui.screens.dialogs import EditDialog
from tui.screens.main import MAIN_WIDGETS

TABS = {"1": "run", "2": "plant", "3": "targets", "4": "history", "5": "sweep"}


@pytest.mark.long
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


@pytest.mark.long
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


@synchronous
async def test_shaping_keys_act_after_a_tab_switch_and_digits_go_to_the_dialog(tmp_path, monkeypatch):
    """Issue 54: after C, a tab switch and back, G opens the phase-margin dialog and the
    digits typed next go into it (they switched tabs: "50" opened the Sweep tab)."""
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        await pilot.press("2", "1")
        await settle(app, pilot)
        await pilot.press("G", "5", "0")
        await pilot.pause()
        assert isinstance(app.screen, EditDialog) and "phase margin" in app.screen.title_text
        assert app.screen.query_one("#value").value == "50"
        await pilot.press("escape")
        await pilot.pause()
        assert app.screen.query_one("#tabs").active == "run"


@synchronous
async def test_shaping_keys_act_from_any_focus_on_the_run_tab(tmp_path, monkeypatch):
    """g from the tableau (the shaping table hidden) shows the table and asks for the
    crossover; on another tab it says where it acts and types nowhere."""
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.focused is app.screen.query_one("#tableau-scroll")
        await pilot.press("g")
        await pilot.pause()
        assert isinstance(app.screen, EditDialog) and "crossover" in app.screen.title_text
        await pilot.press("escape")
        await pilot.pause()
        assert app.focused is app.screen.query_one("#shape")
        await pilot.press("4")  # History: G cannot act there
        await pilot.pause()
        await pilot.press("G")
        await pilot.pause()
        assert app.screen.query_one("#tabs").active == "history" and not isinstance(app.screen, EditDialog)
        why = "the shaping keys act on the Run tab (1, then C shows the shaping table)"
        assert any(str(n.message) == f"shaping: {why}" for n in app._notifications)
        assert said(app) == f"shaping: {why}"  # the line under the status says it too
        await pilot.press("1")  # a key that acts: the line goes
        await pilot.pause()
        assert said(app) is None and app.screen.query_one("#tabs").active == "run"


def said(app) -> str | None:
    """What the line under the status says of a key that cannot act (None: hidden)."""
    line = app.screen.query_one("#refused")
    return line.text.plain if line.display else None


def footer_keys(app) -> dict[str, tuple[bool, str]]:
    """The footer's keys: their description, whether enabled, their tooltip."""
    return {
        key.description: (not key.has_class("-disabled"), str(key.tooltip)) for key in app.screen.query("FooterKey")
    }


@synchronous
async def test_a_shaping_key_that_cannot_act_says_why_on_the_status_line_and_in_the_footer(tmp_path, monkeypatch):
    """On the gain row [ and ] (a pair's damping) cannot act: the footer's key is dimmed with
    the reason as its tooltip, and pressing it says the reason on the status line, changing
    nothing; on a pair they act."""
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        table = app.screen.query_one("#shape")
        assert app.focused is table and table.selected[1].kind == "gain"
        why = "[ and ] move a pair's damping: select a zero pair or a pole pair"
        assert footer_keys(app)["damping -"] == (False, f"damping -: {why}")
        design = app.bench.session.model.model_dump()
        await pilot.press("left_square_bracket")
        await settle(app, pilot)
        assert said(app) == f"damp: {why}" and app.bench.session.model.model_dump() == design
        assert app.focused is table  # typed into nothing else
        await pilot.press("down")  # a key that acts: the reason goes
        await pilot.pause()
        assert said(app) is None


@synchronous
async def test_a_parameter_added_on_the_plant_tab_is_selected(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("2")
        table = app.screen.query_one("#parameters")
        table.focus()
        table.move_cursor(row=0)
        await pilot.press("plus")
        await pilot.pause()
        app.screen.query_one("#value").value = "Kd 0.5 0 10"
        await pilot.press("enter")
        await settle(app, pilot)
        assert table.refs[table.cursor_row] == ("parameters", len(table.refs) - 1)
        assert app.bench.session.model.problem.parameters[-1].name == "Kd"
        before = [p.free for p in app.bench.session.model.problem.parameters]
        await pilot.press("f")  # f acts on the new parameter, not the first one
        await settle(app, pilot)
        after = [p.free for p in app.bench.session.model.problem.parameters]
        assert after[:-1] == before[:-1] and after[-1] != before[-1]

"""Save As (issue 54): f12 (terminals send ctrl+s and ctrl+shift+s alike) and the palette
ask for a name; a new session asks for its name on its first save, then saves in place."""

from __future__ import annotations

import json

from tests.tui.test_app import settle, synchronous
from tests.tui.test_shape_table import lead_app
from tui.screens.dialogs import EditDialog


async def _save_as(app, pilot, key: str, path) -> None:
    await pilot.press(key)
    await pilot.pause()
    assert isinstance(app.screen, EditDialog) and app.screen.title_text.startswith("save as")
    app.screen.query_one("#value").value = str(path)
    await pilot.press("enter")
    await settle(app, pilot)


@synchronous
async def test_f12_saves_under_a_new_name_and_ctrl_s_in_place(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await _save_as(app, pilot, "f12", tmp_path / "named.json")
        assert app.bench.session.path == tmp_path / "named.json" and (tmp_path / "named.json").exists()
        assert "named.json" in str(app.screen.query_one("#status").render())
        await pilot.press("s")
        await settle(app, pilot)
        await pilot.press("ctrl+s")  # a named session: saved in place, nothing asked
        await settle(app, pilot)
        assert not isinstance(app.screen, EditDialog)
        assert json.loads((tmp_path / "named.json").read_text())["current_iteration"] == 1


@synchronous
async def test_a_new_session_asks_for_its_name_on_its_first_save(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        app.bench.untitled = True  # as `ctrl+n` makes it (`LoopcraftApp._create`)
        await pilot.press("ctrl+s")
        await pilot.pause()
        assert isinstance(app.screen, EditDialog)
        app.screen.query_one("#value").value = str(tmp_path / "nowhere" / "x.json")
        await pilot.press("enter")
        await pilot.pause()
        assert "no folder" in str(app.screen.query_one("#error").render())  # refused as typed
        app.screen.query_one("#value").value = str(tmp_path / "mine.json")
        await pilot.press("enter")
        await settle(app, pilot)
        assert app.bench.session.path == tmp_path / "mine.json" and not app.bench.untitled
        await pilot.press("ctrl+s")  # then in place
        await pilot.pause()
        assert not isinstance(app.screen, EditDialog)


@synchronous
async def test_save_as_is_in_the_palette_once(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        titles = [c.title for c in app.get_system_commands(app.screen)]
        assert titles.count("Save as") == 1

"""The workbench's data-loss paths: a new session, opening another file,
quitting, switching the algorithm and out-of-range values never lose work
or close the app; keys that would change the session during a run say why
they do nothing."""

from __future__ import annotations

import asyncio
import time

import pytest

from engine.cip import Cip
from sessions.store import flush_autosaves
from tests.tui.test_app import edit_row, settle, status, synchronous
from tests.tui.test_run_race import send_keys
from tui.app import LoopcraftApp
from tui.screens.dialogs import ConfirmDialog, StartDialog
from tui.screens.main import MainScreen


def messages(app) -> list[str]:
    return [str(n.message) for n in app._notifications]


@pytest.mark.long
@synchronous
async def test_a_new_session_opens_from_the_start_screen_and_from_a_session(workdir):
    app = LoopcraftApp()
    async with app.run_test(size=(100, 32)) as pilot:
        await pilot.pause()
        await pilot.press("n")
        await pilot.pause()
        await pilot.press("enter")  # unity feedback
        await pilot.pause()
        app.screen.query_one("#value").value = "16000/(s*(s+8)*(s+20))"
        await pilot.press("enter")
        await pilot.pause()
        await pilot.press("enter")  # a lead
        await settle(app, pilot)
        assert isinstance(app.screen, MainScreen) and app.is_running
        path = app.bench.session.path
        assert path.parent == workdir / "home" / "new" and "untitled" in status(app)
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 1  # the template steps
        await pilot.press("ctrl+n")  # a new session inside a session
        await pilot.pause()
        assert isinstance(app.screen, ConfirmDialog)  # unsaved work: asked first, autosaved meanwhile
        assert (path.parent / (path.name + ".autosave")).exists()
        await pilot.press("y")
        await pilot.pause()
        await pilot.press("down", "down", "down", "down", "enter")  # a projection problem
        await settle(app, pilot)
        assert app.bench.session.path != path and app.bench.iteration == 0


@synchronous
async def test_opening_another_file_and_quitting_ask_and_autosave_first(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await edit_row(app, pilot, "2", "blocks", 0)
        app.screen.query_one("#value").value = "(s+z1)*(s+z2)/((s+p1)*(s+p2))*1.5"
        await pilot.press("enter")
        await settle(app, pilot)
        assert app.bench.dirty
        autosave = workdir / "report003_lag_lead.json.autosave"
        flush_autosaves()  # written by the autosave thread (the edit's handler does not wait)
        assert autosave.exists() and "*1.5" in autosave.read_text()  # the accepted edit is on disk
        await pilot.press("ctrl+o")
        await pilot.pause()
        assert isinstance(app.screen, ConfirmDialog)
        await pilot.press("n")
        await pilot.pause()
        await pilot.press("q")
        await pilot.pause()
        assert isinstance(app.screen, ConfirmDialog)
        assert "autosaved to report003_lag_lead.json.autosave" in str(app.screen.query("Label").first().render())
        await pilot.press("n")
        await pilot.pause()
        assert app.is_running


@synchronous
async def test_switching_the_algorithm_asks_before_dropping_iterations(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 1
        await pilot.press("a")
        await pilot.pause()
        await pilot.press("down", "enter")  # another algorithm than cip
        await pilot.pause()
        assert isinstance(app.screen, StartDialog)  # the session's first edit that drops iterations asks
        await pilot.press("n")
        await settle(app, pilot)
        assert app.bench.iteration == 1 and app.bench.algorithm_name == "cip"


@synchronous
async def test_a_value_outside_its_bounds_is_refused_as_it_is_typed(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await edit_row(app, pilot, "2", "parameters", 0)  # z1, min 0.01
        await pilot.press("enter")  # "value"
        await pilot.pause()
        field = app.screen.query_one("#value")
        field.value = "-5"
        await pilot.pause()
        assert "outside its bounds [0.01," in str(app.screen.query_one("#error").render())
        await pilot.press("enter")
        await pilot.pause()
        assert app.screen.query_one("#value") is field  # refused: the dialog stays
        await pilot.press("escape")
        await settle(app, pilot)
        assert app.bench.session.model.problem.parameters[0].value == 1.0


@synchronous
async def test_keys_that_change_the_session_say_why_they_wait_during_a_run(workdir, monkeypatch):
    step = Cip.step

    def slow_step(self, state):
        time.sleep(0.01)
        return step(self, state)

    monkeypatch.setattr(Cip, "step", slow_step)
    app = LoopcraftApp(workdir / "cip_dual_channel.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await send_keys(app, "r")
        await asyncio.sleep(0.1)
        assert app.busy
        await send_keys(app, "a")
        await asyncio.sleep(0.05)
        await send_keys(app, "space")
        await settle(app, pilot)
        assert any("choose algorithm: not while a run goes" in m for m in messages(app))
        assert isinstance(app.screen, MainScreen)  # no dialog was opened


@synchronous
async def test_a_file_changed_on_disk_is_not_overwritten_without_asking(workdir):
    path = workdir / "report003_lag_lead.json"
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        other = path.read_text().replace('"notes": "', '"notes": "edited elsewhere. ', 1)
        path.write_text(other)
        await pilot.press("ctrl+s")
        await pilot.pause()
        assert isinstance(app.screen, ConfirmDialog) and path.read_text() == other  # asked; nothing written
        await pilot.press("n")
        await pilot.pause()
        await pilot.press("ctrl+s")
        await pilot.pause()
        await pilot.press("y")
        await settle(app, pilot)
        assert "edited elsewhere" not in path.read_text() and not app.bench.dirty


@synchronous
async def test_a_table_outside_the_sessions_folder_is_read_only_when_allowed(workdir):
    import json

    (workdir / "elsewhere").mkdir()
    (workdir / "report003_lag_lead.json").rename(workdir / "elsewhere" / "s.json")
    doc = json.loads((workdir / "elsewhere" / "s.json").read_text())
    block = doc["problem"]["conditions"][0]["plant"]["blocks"][1]
    (workdir / "plant.csv").write_text("hz,mag,deg\n0.01,100,-90\n1,1,-120\n100,0.001,-180\n")
    block["transfer"] = {
        "kind": "table",
        "table": {"csv": "../plant.csv", "columns": ["hz", "mag", "deg"], "form": "polar", "unit": "hz"},
    }
    (workdir / "elsewhere" / "s.json").write_text(json.dumps(doc))
    app = LoopcraftApp(workdir / "elsewhere" / "s.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        assert isinstance(app.screen, ConfirmDialog)
        assert "../plant.csv" in str(app.screen.query("Label").first().render())
        await pilot.press("y")
        await settle(app, pilot)
        assert isinstance(app.screen, MainScreen) and app.bench.session.allow_outside_tables


@synchronous
async def test_a_declined_autosave_is_set_aside_and_not_offered_again(workdir):
    import os

    path = workdir / "report003_lag_lead.json"
    autosave = workdir / "report003_lag_lead.json.autosave"
    autosave.write_text(path.read_text())
    os.utime(autosave, (path.stat().st_mtime + 10, path.stat().st_mtime + 10))
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert isinstance(app.screen, ConfirmDialog)
        await pilot.press("n")
        await settle(app, pilot)
        assert not autosave.exists()
        aside = list(workdir.glob("report003_lag_lead.json.autosave.declined-*"))
        assert len(aside) == 1 and aside[0].read_text() == path.read_text()  # kept, not lost
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert not isinstance(app.screen, ConfirmDialog)

"""ctrl+e exports the current design beside the session; S saves an SVG screenshot there."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.screens.dialogs import ConfirmDialog


@pytest.mark.long
@synchronous
async def test_export_and_screenshot_land_beside_the_session(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        await pilot.press("ctrl+e")
        await pilot.pause()
        await pilot.press("enter")  # python
        await settle(app, pilot)
        script = workdir / "report003_lag_lead_iter1.py"
        assert script.exists()
        await pilot.press("S")
        await settle(app, pilot)
        svg = workdir / "report003_lag_lead_iter1.svg"
        assert svg.read_text().startswith("<svg") and "Iteration 1" in svg.read_text().replace("&#160;", " ")
        await pilot.press("S")  # a second screenshot of the iteration: a second file, no question
        await settle(app, pilot)
        assert not isinstance(app.screen, ConfirmDialog) and (workdir / "report003_lag_lead_iter1-2.svg").exists()
        await pilot.press("ctrl+e")  # the same design exported again: asked before it is replaced
        await pilot.pause()
        await pilot.press("enter")
        await pilot.pause()
        assert isinstance(app.screen, ConfirmDialog)
        await pilot.press("n")
        titles = [c.title for c in app.get_system_commands(app.screen)]
        assert titles.count("Screenshot") == 1 and titles.count("Keys") == 1  # the palette: one each
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "margin" in out.stdout.lower()


@synchronous
async def test_a_new_session_saved_joins_the_recent_list_and_the_header_says_not_running(workdir):
    """Issue 37 section 7: ctrl+s of a new session left the recent list as it was; the
    header said 'Iteration 1 running' when nothing ran."""
    from tui.files import recent_sessions

    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")  # 16 iterations to converge
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        assert "running" not in app.bench.status_text() and "not finished" in app.bench.status_text()
        target = workdir / "saved_as_new.json"
        app.bench.session.path = None  # as a new session is, before its first save
        app._save(target)
        await settle(app, pilot)
        assert target.resolve() in [p.resolve() for p in recent_sessions()]

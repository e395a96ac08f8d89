"""ctrl+e exports the current design beside the session; S saves an SVG screenshot there."""

from __future__ import annotations

import subprocess
import sys

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.screens.dialogs import ConfirmDialog


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
        await pilot.press("S")  # exists: asked before it is replaced
        await pilot.pause()
        assert isinstance(app.screen, ConfirmDialog)
        await pilot.press("n")
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "margin" in out.stdout.lower()

"""What the user types or opens never kills the app (issue 35, section 7): a path
over 255 bytes in ctrl+o, a time target added to a problem without conditions,
a session whose algorithm name is empty (a, s, z, Z) are messages."""

from __future__ import annotations

import json

from tests.sessions.conftest import MATCHING
from tests.tui.test_app import synchronous
from tui.app import LoopcraftApp
from tui.files import file_problem
from tui.screens.main import MainScreen


def _errors(app) -> list[str]:
    return [n.message for n in app._notifications if n.severity == "error"]


def test_file_problem_never_raises(tmp_path):
    assert file_problem(tmp_path / ("x" * 300)) is not None and "ENAMETOOLONG" in file_problem(tmp_path / ("x" * 300))
    assert file_problem(tmp_path) == "not a regular file"
    assert file_problem(tmp_path / "none.json") == "no such file"
    assert file_problem(tmp_path / "a\0b") == "not a file name"


@synchronous
async def test_a_path_over_255_bytes_typed_in_open_is_a_message(workdir):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        await pilot.press("ctrl+o")
        await pilot.pause()
        long = str(workdir / ("y" * 300 + ".json"))
        app.screen.query_one("Input").value = long
        await pilot.press("enter")
        await pilot.pause()
        app.open_path(workdir / ("z" * 300 + ".json"))  # past the dialog's check, too
        await pilot.pause()
        assert app.is_running and app.bench is not None
        assert any("ENAMETOOLONG" in m for m in _errors(app))


@synchronous
async def test_a_target_added_without_conditions_is_a_message(workdir):
    app = LoopcraftApp(workdir / "projection_integrator.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        await pilot.press("3")
        await pilot.pause()
        app.screen.query_one("#targets").focus()
        for measure in ("rise_time", "phase_margin_deg"):
            await pilot.press("plus")
            await pilot.pause()
            app.screen.query_one("OptionList").highlighted = [name for name, _ in app.screen.choices].index(measure)
            await pilot.press("enter")
            await pilot.pause()
        assert app.is_running and isinstance(app.screen, MainScreen)
        assert any("has none" in m for m in _errors(app))


@synchronous
async def test_an_empty_algorithm_name_is_a_message_on_every_key(workdir):
    from tui.cli import main

    path = workdir / "s.json"
    path.write_text(json.dumps(MATCHING))
    assert main(["run", str(path), "--iterations", "2"]) == 0
    doc = json.loads(path.read_text())
    doc["algorithm"]["name"] = ""
    path.write_text(json.dumps(doc))
    before = path.read_bytes()
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        for key in ("a", "escape", "s", "z", "z", "Z", "Z", "n", "escape", "r"):
            await pilot.press(key)
            await pilot.pause()
        assert app.is_running and isinstance(app.screen, MainScreen)
        assert any("unknown algorithm ''" in m for m in _errors(app))
    assert path.read_bytes() == before

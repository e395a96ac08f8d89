"""An edit that drops recorded iterations keeps the design on screen as the new start
(issue 38, section 3): the session's first such edit asks (the design on screen, or back
to the saved start), the answer holds, every edit says which iterations it dropped, and
ctrl+z brings them back with the old start."""

from __future__ import annotations

import pytest

from tests.tui.test_app import edit_row, settle, synchronous
from tui.app import LoopcraftApp
from tui.screens.dialogs import StartDialog


def _start(app) -> dict[str, float]:
    return {p.name: p.value for p in app.bench.session.model.problem.parameters}


async def _steps(app, pilot, count: int) -> dict[str, float]:
    for _ in range(count):
        await pilot.press("s")
        await settle(app, pilot)
    return dict(app.bench.records[-1].parameters)


async def _edit_band(app, pilot, text: str) -> None:
    await edit_row(app, pilot, "3", "targets-table", 2)
    await pilot.press("enter")
    await pilot.pause()
    app.screen.query_one("#value").value = text
    await pilot.press("enter")
    await pilot.pause()


@pytest.mark.long
@synchronous
async def test_an_edit_keeps_the_design_on_screen_and_says_what_it_dropped(workdir):
    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        saved = _start(app)
        design = await _steps(app, pilot, 2)
        assert design != {k: v for k, v in saved.items() if k in design}
        await _edit_band(app, pilot, "0.5..8: 45 / 35")
        assert isinstance(app.screen, StartDialog)  # the first such edit asks
        await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.iteration == 0 and app.bench.session.problem.targets[2].bands[0].desired == 45.0
        assert all(_start(app)[name] == value for name, value in design.items())
        assert any("iterations 1-2 dropped; iteration 2's design is the start" in n.message for n in app._notifications)
        again = await _steps(app, pilot, 1)
        await _edit_band(app, pilot, "0.5..8: 40 / 30")  # the answer holds: no question
        await settle(app, pilot)
        assert not isinstance(app.screen, StartDialog) and app.bench.iteration == 0
        assert all(_start(app)[name] == value for name, value in again.items())
        await pilot.press("ctrl+z")  # the edit undone: its iteration and the start before it are back
        await settle(app, pilot)
        assert app.bench.iteration == 1 and all(_start(app)[n] == v for n, v in design.items())


@pytest.mark.long
@synchronous
async def test_the_saved_start_is_the_other_answer_and_holds(workdir):
    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        saved = _start(app)
        await _steps(app, pilot, 1)
        await _edit_band(app, pilot, "0.5..8: 45 / 35")
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 0 and _start(app) == saved and app.bench.start == "saved"
        await _steps(app, pilot, 1)
        await pilot.press("a")  # switching the algorithm is an edit too: back to the saved start, no question
        await pilot.pause()
        await pilot.press("down", "enter")
        await settle(app, pilot)
        assert not isinstance(app.screen, StartDialog) and _start(app) == saved


@pytest.mark.long
@synchronous
async def test_a_run_after_an_edit_starts_from_the_kept_design(workdir):
    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        design = await _steps(app, pilot, 2)
        await _edit_band(app, pilot, "0.5..8: 40 / 30")  # the same band: only the design moves
        await pilot.press("y")
        await settle(app, pilot)
        assert all(_start(app)[name] == value for name, value in design.items())
        await pilot.press("s")  # the next step moves from the kept design, not from the saved start
        await settle(app, pilot)
        view = app.bench.view()
        for k in range(len(view.problem.conditions)):
            start = view.parameters(0, k)
            assert all(start[n] == (v[k] if isinstance(v, list) else v) for n, v in design.items())

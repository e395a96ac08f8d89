"""The key footer: rebuilt once for the binding refreshes of a step's end (Textual's
rebuilt itself once per refresh, three times per step: half the time from the key
press to the painted iteration), and still dimming the session's keys in a run."""

from __future__ import annotations

import time

import pytest
from textual.widgets._footer import FooterKey

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.widgets.footer import Footer


def _disabled(app, action: str) -> bool:
    """Whether the footer shows the key of ``action`` dimmed."""
    return next(key for key in app.screen.query(FooterKey) if key.action == action).has_class("-disabled")


def _counted_rebuilds(monkeypatch) -> list[float]:
    """The times the footer is recomposed from now on (whether or not the recomposition then
    finds anything to change)."""
    rebuilds = []
    recompose = Footer.recompose

    async def counted(self):
        rebuilds.append(time.perf_counter())
        await recompose(self)

    monkeypatch.setattr(Footer, "recompose", counted)
    return rebuilds


@synchronous
async def test_a_step_rebuilds_the_footer_at_most_twice(workdir, monkeypatch):
    rebuilds = _counted_rebuilds(monkeypatch)
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert _disabled(app, "undo")  # nothing to undo yet
        rebuilds.clear()
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 1 and not _disabled(app, "undo")
        assert 1 <= len(rebuilds) <= 2  # one, or two when the step outlasts the dimming delay
        assert isinstance(app.screen.query_one("Footer"), Footer)


@synchronous
async def test_binding_refreshes_before_a_rebuild_make_one_rebuild(workdir, monkeypatch):
    rebuilds = _counted_rebuilds(monkeypatch)
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        rebuilds.clear()
        app.runs.running = True  # the session's keys disabled: the footer has something new to show
        for _ in range(3):
            app.screen.refresh_bindings()
        await settle(app, pilot)
        assert len(rebuilds) == 1
        app.runs.running = False
        app.screen.refresh_bindings()  # a later refresh that changes a key rebuilds again
        await settle(app, pilot)
        assert len(rebuilds) == 2


@synchronous
async def test_a_run_dims_the_session_keys_and_its_end_enables_them(workdir, monkeypatch):
    app = LoopcraftApp(workdir / "cip_dual_channel.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        stepper = type(app.bench.ensure_stepper())  # a bound stepper is frozen: its class is patched
        step = stepper.step

        def slow_step(self, state):  # 20 ms iterations: the run outlasts the dimming delay
            time.sleep(0.02)
            return step(self, state)

        monkeypatch.setattr(stepper, "step", slow_step)
        assert not _disabled(app, "step")
        await pilot.press("r")
        await pilot.pause(0.5)
        assert app.busy and _disabled(app, "step")
        await pilot.press("space")
        await settle(app, pilot)
        assert not app.busy and not _disabled(app, "step")


@pytest.mark.long
@synchronous
async def test_a_nudge_does_not_rebuild_the_footer(tmp_path, monkeypatch):
    """Issue 54: a nudge in the shaping table changes no key, and the footer is not
    recomposed (the profile found `Footer.recompose` on every nudge: Textual's rebuild,
    7 % of its time, later a recompose that found the same keys and stopped); a key that
    changes state does."""
    from tests.tui.test_shape_table import lead_app

    rebuilds = _counted_rebuilds(monkeypatch)
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        await pilot.press("down", "left")
        await settle(app, pilot)  # the first edit: ctrl+z's key now acts (not shown in the footer)
        rebuilds.clear()
        before = app.bench.session.model.problem.model_dump()
        for key in ("right", "left", "right"):
            await pilot.press(key)
            await settle(app, pilot)
        assert app.bench.session.model.problem.model_dump() != before and rebuilds == []
        await pilot.press("up")  # the gain selected: [ (a pair's damping) stays disabled, delete too
        await settle(app, pilot)
        assert len(rebuilds) == 1

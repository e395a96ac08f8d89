"""The root locus as a design tool (issue 38, section 1): the cursor along a branch reads
the gain there and the closed-loop poles it gives; enter makes that gain the design's
(through the gain parameter), and the new design's closed-loop poles (python-control)
include the point the cursor was on."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.cli import main


def _lead(tmp_path):
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    return path


@pytest.mark.long
@synchronous
async def test_enter_on_the_locus_adopts_the_gain_at_the_cursor(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    app = LoopcraftApp(_lead(tmp_path))
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        app.screen.query_one("#plots").active = "p-locus"
        await settle(app, pilot)
        await settle(app, pilot)
        plot = app.screen.query_one("#locus")
        await pilot.press("P", "right")
        await pilot.press(*["right"] * 40)
        await pilot.pause()
        probe, i = plot.figure.probe, plot.navigation.cursor
        point = complex(probe.x[i], probe.y[i])
        k = probe.chosen(i)
        assert plot.shown.title.startswith(f"k = {k:.5g}: poles ")
        before = {p.name: p.value for p in app.bench.session.model.problem.parameters}
        await pilot.press("enter")
        await settle(app, pilot)
        after = {p.name: p.value for p in app.bench.session.model.problem.parameters}
        assert after["K"] == before["K"] * k and after["T1"] == before["T1"]
        lead = ct.tf([after["K"] * after["T1"], after["K"]], [after["T2"], 1])
        poles = ct.feedback(lead * ct.tf([1], [1, 10, 0, 0]), 1).poles()
        assert np.min(np.abs(poles - point)) < 1e-6 * max(1.0, abs(point))


@synchronous
async def test_enter_is_disabled_on_a_plot_that_picks_nothing(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("P", "right")
        await pilot.pause()
        plot = app.screen.query_one("#nyquist")
        assert app.focused is plot and plot.check_action("choose", ()) is None

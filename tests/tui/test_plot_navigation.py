"""Zoom, pan and the cursor on the plots; the readout is the engine's response there."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.figures.navigation import log_ticks


def _loop(s):
    return (s + 1) * (s + 5) / ((s + 0.1) * (s + 50)) * 16000 / (s * (s + 8) * (s + 20))


@pytest.mark.long
@synchronous
async def test_zoom_pan_cursor_and_reset_on_the_bode_plot(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        app.screen.query_one("#plots").active = "p-bode"
        await settle(app, pilot)
        plot = app.screen.query_one("#bode-mag")
        plot.focus()
        await pilot.press("right")  # the cursor appears mid-curve
        await pilot.press(*["right"] * 5)
        await pilot.pause()
        shown = plot.shown
        i = plot.navigation.cursor
        probe = plot.figure.probe
        w = 10 ** probe.x[i]
        expected = _loop(1j * w)
        words = shown.title.split()
        assert float(words[2]) == float(f"{w:.6g}")
        assert abs(float(words[6]) - 20 * math.log10(abs(expected))) < 1e-4
        assert abs(float(words[10]) - math.degrees(np.angle(expected))) < 1e-3
        whole = plot.figure.xlim, plot.figure.ylim
        await pilot.press("plus")
        await pilot.pause()
        x0, x1, y0, y1 = plot.navigation.box
        assert x0 < probe.x[i] < x1 and y0 < probe.y[i] < y1 and shown.xticks is not None
        width = x1 - x0
        await pilot.press("l")
        await pilot.pause()
        assert math.isclose(plot.navigation.box[0], x0 + 0.25 * width) and plot.shown.xticks[1]
        phase = app.screen.query_one("#bode-phase")  # linked (issue 54): its frequency range and cursor follow
        assert phase.navigation.box[:2] == plot.navigation.box[:2] and phase.navigation.cursor == i
        assert phase.navigation.box[2:] != plot.navigation.box[2:]  # its own phase range
        await pilot.press("minus")
        await pilot.press("0")
        await pilot.pause()
        assert plot.navigation.box is None and plot.navigation.cursor is None
        assert phase.navigation.box is None and phase.navigation.cursor is None
        assert (plot.shown.xlim, plot.shown.ylim) == whole
        await pilot.press("1")  # the tab keys still work from a plot
        await pilot.pause()
        assert app.screen.query_one("#tabs").active == "run"


def test_zoomed_log_ticks_are_frequencies_inside_the_box():
    ticks, labels = log_ticks(math.log10(3), math.log10(70))
    assert labels == ["5", "10", "20", "50"] and all(math.log10(3) <= t <= math.log10(70) for t in ticks)
    ticks, labels = log_ticks(0.301, 0.302)
    assert len(ticks) == 3 and all(0.301 <= t <= 0.302 for t in ticks)


def test_zoom_and_pan_stay_within_what_a_float_can_draw():
    """'-' pressed 13 times on the Bode plot killed the app (log_ticks took 10**-324 as 0);
    a box is kept within 1e-300..1e300 on a log axis and +-1e300 on a linear one: a key that
    would leave that does nothing, and every box left is drawn."""
    from tui.drawing.text_canvas import draw
    from tui.figures.data import Figure, Series
    from tui.figures.navigation import ZOOM, Navigation

    for log_x in (True, False):
        figure = Figure(series=[Series([-1.0, 0.0, 2.0], [-40.0, 0.0, 30.0], "gain")], log_x=log_x)
        navigation = Navigation()
        for factor, moves in ((1 / ZOOM, 2000), (ZOOM, 4000)):
            for _ in range(moves):
                navigation.zoom(figure, factor)
                navigation.pan(figure, 0.25, -0.25)
            x0, x1, y0, y1 = navigation.box
            assert x0 < x1 and y0 < y1 and max(abs(x0), abs(x1)) <= (300 if log_x else 1e300)
            shown = navigation.applied(figure)
            assert all(math.isfinite(t) for t in (shown.xticks or ([0.0], []))[0])
            assert draw(shown, 80, 20, "dark") is not None


def test_a_click_on_a_plot_with_an_empty_curve_puts_no_cursor():
    from tui.figures.data import Figure, Series
    from tui.figures.navigation import Navigation, xy_probe

    empty = xy_probe(Series([], [], "nothing yet"), "x", "y")
    navigation = Navigation()
    navigation.pick(Figure(probe=empty), 0.5, 0.5, (10.0, 10.0))
    assert navigation.cursor is None
    navigation.pick(Figure(series=[Series([0.0, 1.0], [0.0, 0.9], "gain")], probe=empty), 0.9, 0.9, (10.0, 10.0))
    assert navigation.cursor == 1 and navigation.picked.x == [0.0, 1.0]


def test_the_bode_cursor_reads_the_phase_on_the_branch_the_axis_draws():
    """Issue 54: 7 (1 + s)/(s^2 (s + 10) (1 + s/5)) starts just above -180 deg and is drawn
    down to about -232 deg at 20 rad/s, where the cursor read +128 (numpy's principal
    angle).  Every probe of the loop (Bode magnitude and phase, Nichols, Nyquist) reads the
    branch drawn, as the margin marks do (`LoopCurve.on_branch`)."""
    from engine.analysis import LoopCurve
    from tui.figures.open_loop import bode_figures, nichols_figure, nyquist_figure

    omega = np.geomspace(0.01, 100, 401)
    s = 1j * omega
    curve = LoopCurve(omega, 7 * (1 + s) / (s**2 * (s + 10) * (1 + s / 5)), "current")
    magnitude, phase = bode_figures([curve], "rad/s")
    i = int(np.argmin(abs(omega - 20.0)))
    drawn = phase.probe.y[i]
    w = omega[i]
    expected = -180 + math.degrees(math.atan(w) - math.atan(w / 10) - math.atan(w / 5))
    assert drawn == pytest.approx(expected, abs=1e-9) and drawn < -200
    probes = [magnitude.probe, phase.probe, nichols_figure([curve], "rad/s").probe, nyquist_figure([curve], []).probe]
    for probe in probes:
        assert f"phase = {drawn:.3f} deg" in probe.readout(i)

"""The mouse on a plot (issue 36, section 2): the wheel zooms about the pointer, a drag
pans, a click puts the data tip on the nearest point of the nearest curve; P focuses a
tab's plot, p keeps the focus on the plots, and the focus shows."""

from __future__ import annotations

import math

from textual import events

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp


def _post(plot, kind, col: int, row: int, button: int = 0) -> None:
    """A mouse event at a cell of the plot's content, sent to the app as the terminal's
    driver does (the screen forwards it to the widget under the pointer, or the captor)."""
    content = plot.content_region
    sx, sy = content.x + col, content.y + row
    plot.app.post_message(kind(None, sx, sy, 0, 0, button, False, False, False, screen_x=sx, screen_y=sy))


async def _bode(pilot, app, example: str = "lead_sensitivity_peak"):
    await settle(app, pilot)
    app.screen.query_one("#plots").active = "p-bode"
    await settle(app, pilot)
    plot = app.screen.query_one("#bode-mag")
    await pilot.pause()
    return plot


def _cell_size(frame) -> tuple[float, float]:
    return (frame.xlim[1] - frame.xlim[0]) / (frame.right - frame.left), (frame.ylim[1] - frame.ylim[0]) / (
        frame.bottom - frame.top
    )


@synchronous
async def test_the_wheel_zooms_about_the_point_under_the_pointer(workdir):
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        plot = await _bode(pilot, app)
        frame = plot.drawing.frames[0]
        cell = (frame.left + (frame.right - frame.left) // 4, frame.top + 2)
        before = frame.point(*cell)
        _post(plot, events.MouseScrollUp, *cell)
        await pilot.pause()
        after = plot.drawing.frames[0]
        x, y = after.point(*cell)
        dx, dy = _cell_size(frame)
        assert abs(x - before[0]) < dx and abs(y - before[1]) < dy  # the point stays under the pointer
        assert after.xlim[1] - after.xlim[0] < 0.9 * (frame.xlim[1] - frame.xlim[0])  # and it zoomed in
        _post(plot, events.MouseScrollDown, *cell)
        await pilot.pause()
        assert math.isclose(
            plot.drawing.frames[0].xlim[1] - plot.drawing.frames[0].xlim[0], frame.xlim[1] - frame.xlim[0]
        )


@synchronous
async def test_a_drag_pans_with_the_pointer(workdir):
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        plot = await _bode(pilot, app)
        frame = plot.drawing.frames[0]
        start, end = (frame.left + 10, frame.top + 3), (frame.left + 30, frame.top + 6)
        grabbed = frame.point(*start)
        _post(plot, events.MouseDown, *start, button=1)
        _post(plot, events.MouseMove, *end, button=1)
        _post(plot, events.MouseUp, *end, button=1)
        await pilot.pause()
        moved = plot.drawing.frames[0]
        x, y = moved.point(*end)
        dx, dy = _cell_size(frame)
        assert abs(x - grabbed[0]) < dx and abs(y - grabbed[1]) < dy  # the grabbed point is under the pointer
        assert plot.navigation.cursor is None  # a drag is no click


@synchronous
async def test_a_click_puts_the_data_tip_on_the_nearest_curve(workdir):
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        plot = await _bode(pilot, app)
        frame = plot.drawing.frames[0]
        probe = plot.figure.probe
        i = len(probe.x) // 3
        col, row = frame.cells(probe.x[i], probe.y[i])
        _post(plot, events.MouseDown, round(col), round(row), button=1)
        _post(plot, events.MouseUp, round(col), round(row), button=1)
        await pilot.pause()
        j = plot.navigation.cursor
        assert j is not None and plot.navigation.picked is None  # on the current design's curve
        near = frame.cells(probe.x[j], probe.y[j])
        assert abs(near[0] - col) <= 1 and abs(near[1] - row) <= 1
        assert plot.shown.title.startswith("w = ")  # the loop's readout: frequency, gain, phase
        app.screen.focus_main("run")  # the click focused the Bode plot: its tab would stay
        app.screen.query_one("#plots").active = "p-nyquist"  # the unit circle, away from the loop's curve
        await settle(app, pilot)
        plot = app.screen.query_one("#nyquist")
        frame, probe = plot.drawing.frames[0], plot.figure.probe
        circle = plot.figure.series[0]
        apart = [
            min(math.dist(frame.cells(x, y), frame.cells(px, py)) for px, py in zip(probe.x, probe.y))
            if frame.contains(*map(round, frame.cells(x, y)))
            else 0.0
            for x, y in zip(circle.x, circle.y)
        ]
        k = apart.index(max(apart))
        assert apart[k] > 3
        col, row = frame.cells(circle.x[k], circle.y[k])
        _post(plot, events.MouseDown, round(col), round(row), button=1)
        _post(plot, events.MouseUp, round(col), round(row), button=1)
        await pilot.pause()
        assert plot.navigation.picked is not None and plot.shown.title.startswith("Re GH = ")
        j = plot.navigation.cursor
        assert math.dist(frame.cells(circle.x[j], circle.y[j]), (col, row)) <= 1.5


@synchronous
async def test_one_key_focuses_the_plot_and_the_focus_shows(workdir):
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = app.screen.query_one("#nyquist")
        unfocused = plot.styles.border_left
        await pilot.press("P")
        await pilot.pause()
        assert app.focused is plot and plot.styles.border_left != unfocused
        await pilot.press("p")  # the next plot: the focus goes with it
        await settle(app, pilot)
        assert app.focused is not plot and app.focused.id == "bode-mag"
        await pilot.press("3")
        await pilot.pause()
        assert app.screen.check_action("focus_plot", ()) is None  # no plot on Targets: disabled
        await pilot.press("4", "P")
        await pilot.pause()
        assert app.focused.id == "history-plot"

"""Plots as images where the terminal shows them (issue 36, section 6): the same figure
drawn by matplotlib at the widget's pixel size, the data where its frame says (the
mouse reads it), and the workbench's plot widget showing it in an image child with the
same zoom; without a graphics protocol the plots stay text and the app says why."""

from __future__ import annotations

import numpy as np

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.drawing import image_canvas
from tui.drawing.graphics import Graphics
from tui.figures.data import Figure, Series

CELL = (8, 16)


def test_a_point_is_drawn_where_the_frame_puts_it():
    fig = Figure(title="one point", xlim=(0.0, 10.0), ylim=(-1.0, 1.0))
    fig.series.append(Series([0.0, 10.0], [0.0, 0.0], "a line", color="gray"))
    fig.series.append(Series([7.5], [0.5], "the point", marker="o", scatter=True, color="red"))
    picture, frames = image_canvas.draw(fig, (60, 20), CELL, dark=True)
    assert picture.size == (60 * CELL[0], 20 * CELL[1]) and len(frames) == 1
    pixels = np.asarray(picture).astype(int)
    red = (pixels[..., 0] > 180) & (pixels[..., 1] < 90) & (pixels[..., 2] < 90)
    frame = frames[0]
    inside = np.zeros_like(red)
    inside[frame.top * CELL[1] : (frame.bottom + 1) * CELL[1], frame.left * CELL[0] : (frame.right + 1) * CELL[0]] = (
        True
    )
    rows, cols = np.nonzero(red & inside)  # (the legend's sample of the point is red too)
    col, row = frame.cells(7.5, 0.5)
    assert rows.size and abs(cols.mean() / CELL[0] - col) < 1.0 and abs(rows.mean() / CELL[1] - row) < 1.0
    assert 0 < frame.left < frame.right < 60 and 0 < frame.top < frame.bottom < 20  # the legend below the axes


@synchronous
async def test_the_workbench_draws_images_with_the_same_zoom(workdir):
    from textual_image.widget import UnicodeImage

    app = LoopcraftApp(workdir / "report003_lag_lead.json", graphics=Graphics("test", UnicodeImage, CELL))
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = app.screen.query_one("#nyquist")
        await pilot.pause()
        first = plot.image.image
        width, height = plot.content_size
        assert first is not None and first.size == (width * CELL[0], (height - 1) * CELL[1])
        assert plot.drawing is not None and plot.drawing.frames
        await pilot.press("P", "plus")
        await settle(app, pilot)
        await pilot.pause()
        assert plot.navigation.box is not None and plot.image.image is not first
        zoomed = plot.drawing.frames[0]
        assert zoomed.xlim[1] - zoomed.xlim[0] < 0.7 * 6.0  # the Nyquist's 6-wide axis, zoomed 1.5x


@synchronous
async def test_image_plots_asked_of_a_text_terminal_stay_text_and_say_why(workdir, monkeypatch, tmp_path):
    config = tmp_path / "config.toml"
    config.write_text('plots = "image"\n')
    monkeypatch.setenv("LOOPCRAFT_CONFIG", str(config))
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.screen.query_one("#nyquist").image is None
        assert any("shows no images" in n.message for n in app._notifications)

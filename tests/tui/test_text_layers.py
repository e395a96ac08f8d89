"""A figure drawn in layers (issue 55, section 2): the static layer kept per canvas and view,
the series that changed rasterized over a copy of it (`tui.drawing.text_layers`), gives the
text plotext draws for the whole figure, character by character and colour by colour; and
the plot widget's strips read straight off a drawing's runs (`DrawingVisual`) are the ones
Rich's render gives (`RichVisual`), segment by segment."""

from __future__ import annotations

import math
import random

import pytest
from textual.app import App, ComposeResult
from textual.visual import RichVisual, Visual

from tests.tui.test_app import synchronous
from tests.tui.test_canvas_text import CANVASES, _every_kind
from tui.drawing import text_canvas, text_layers
from tui.figures.data import Figure, Series
from tui.widgets.plots import DrawingVisual, FigurePlot

THEME = "textual-dark"
MARKERS = ("braille", "braille", "dot", "*", "z", "─", "·")
COLOURS = ("blue", "red", "gray", "green", None, None, "no such colour")  # None and unknown: plotext picks one


def _whole(figure: Figure, width: int, height: int) -> text_canvas.Text:
    """Plotext's drawing of the whole figure (no layers)."""
    spans = [text_canvas._spans(figure)]
    return text_canvas.canvas_text(text_canvas._plotted(figure, spans, width, height, THEME))


def _random_series(rng: random.Random) -> Series:
    """A line or scatter of 1 to 60 points over and beyond the view (0..10 both ways), some
    unsorted, some with a missing point."""
    n = rng.randint(1, 60)
    x = [rng.uniform(-2, 12) for _ in range(n)]
    x = sorted(x) if rng.random() < 0.7 else x
    y = [rng.uniform(-3, 13) for _ in range(n)]
    if n > 3 and rng.random() < 0.3:
        y[rng.randrange(n)] = math.nan
    return Series(
        x,
        y,
        marker=rng.choice(MARKERS),
        scatter=rng.random() < 0.3,
        color=rng.choice(COLOURS),
        beneath=rng.random() < 0.2,
    )


def test_series_drawn_over_a_static_layer_are_plotext_s_whole_drawing(monkeypatch: pytest.MonkeyPatch) -> None:
    """Seeded figures (lines and scatters, braille and characters, points off the view and
    missing, colours given, unknown and none), two on each canvas and view: each, drawn over
    the static layer (the one built for the first), is the text plotext draws for it whole."""
    rng = random.Random(55)
    for _ in range(40):
        monkeypatch.setattr(text_canvas, "LAYERS", text_layers.Layers())
        width, height = rng.randint(20, 100), rng.randint(6, 30)
        view = {"title": "t", "xlabel": "x", "ylabel": "y", "xlim": (0.0, 10.0), "ylim": (0.0, 10.0)}
        for _ in range(2):
            figure = Figure(**view, series=[_random_series(rng) for _ in range(rng.randint(1, 5))])
            text = text_canvas.layered_text(figure, text_canvas._spans(figure), width, height, THEME)
            whole = _whole(figure, width, height)
            assert text is not None
            assert (text.plain, text.spans) == (whole.plain, whole.spans)
        assert text_canvas.LAYERS.builds == 1


def test_a_static_layer_is_built_once_for_a_canvas_and_view(monkeypatch: pytest.MonkeyPatch) -> None:
    """Figures whose series move over one view build its static layer once, each drawing
    plotext's whole one (its text and its data area); another view builds its own."""
    monkeypatch.setattr(text_canvas, "LAYERS", text_layers.Layers())

    def figure(k: int, top: float) -> Figure:
        moving = Series([0.0, 5.0, 10.0], [1.0 + k, 5.0 - k / 3, 9.0], "current", color="blue")
        fixed = Series([0.0, 10.0], [2.0, 2.0], "reference", marker="─", color="gray", beneath=True)
        return Figure(title="t", xlim=(0.0, 10.0), ylim=(0.0, top), series=[fixed, moving])

    builds = []
    for k, top in enumerate((10.0, 10.0, 10.0, 10.0, 12.0, 12.0)):
        drawing = text_canvas.draw(figure(k, top), 60, 20, THEME)
        with monkeypatch.context() as whole:
            whole.setattr(text_canvas, "layered_text", lambda *args: None)
            expected = text_canvas.draw(figure(k, top), 60, 20, THEME)
        assert drawing is not None and expected is not None
        assert (drawing.text.plain, drawing.text.spans) == (expected.text.plain, expected.text.spans)
        assert drawing.frames == expected.frames
        builds.append(text_canvas.LAYERS.builds)
    assert builds == [1, 1, 1, 1, 2, 2]


def test_canvas_points_are_plotext_s() -> None:
    """`canvas_points` is plotext's `get_matrix_data` value for value: seeded values over and
    beyond the limits, and values whose cell position lands on or within 1e-9 of a whole
    number or a half (where its rounding to 8 digits decides the cell)."""
    from plotext._utility import get_matrix_data

    rng = random.Random(54)
    for _ in range(200):
        low = rng.uniform(-100, 100)
        limits, bins = (low, low + rng.choice([1e-6, 0.3, 7.0, 1e3])), rng.randint(2, 300)
        cells = [rng.randint(-bins, 2 * bins) + rng.choice([0.0, 0.5, 1e-9, -1e-9, 5e-9, -5e-9]) for _ in range(20)]
        edges = [limits[0] + (c - 0.5) / (bins - 1) * (limits[1] - limits[0]) for c in cells]
        values = edges + [rng.uniform(limits[0] - 5, limits[1] + 5) for _ in range(20)] + [math.nan]
        ours = text_layers.canvas_points(values, limits, bins)
        theirs = get_matrix_data(values, list(limits), bins)
        assert math.isnan(ours[-1]) and math.isnan(theirs[-1])
        assert ours[:-1].tolist() == theirs[:-1]
    with pytest.raises(OverflowError):
        text_layers.canvas_points([math.inf], (0.0, 1.0), 10)
    with pytest.raises(ZeroDivisionError):
        text_layers.canvas_points([1.0], (1.0, 1.0), 10)


@synchronous
async def test_a_drawing_s_strips_are_rich_s() -> None:
    """Every plot kind the workbench draws, at the dragged Bode plot's canvas and a compact
    one, and at a narrower widget (its lines wider: Rich wraps them, so `RichVisual` draws
    it): `DrawingVisual`'s strips are `RichVisual`'s, segment by segment and style by style."""

    class Plots(App):
        def compose(self) -> ComposeResult:
            yield FigurePlot()

    async with Plots().run_test(size=(100, 30)) as pilot:
        plot = pilot.app.query_one(FigurePlot)
        compared = 0
        for name, figure in _every_kind().items():
            for width, height in CANVASES:
                drawing = text_canvas.draw(figure, width, height, THEME)
                if drawing is None:
                    continue
                for shown in (width, width - 3):
                    ours = Visual.to_strips(plot, DrawingVisual(plot, drawing.text), shown, height, plot.visual_style)
                    rich = Visual.to_strips(plot, RichVisual(plot, drawing.text), shown, height, plot.visual_style)
                    assert [list(s) for s in ours] == [list(s) for s in rich], (name, width, height, shown)
                    compared += 1
        assert compared >= 30

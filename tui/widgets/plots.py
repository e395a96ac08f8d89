"""The text plots (the only module that touches plotext).

Each plot keeps plain lists of its series and redraws from them inside
`render` (plotext's `build` rewrites stored data, so a redraw from stored
figure state could lie).  Log-frequency axes are drawn as log10(omega) on a
linear axis with decade labels, never with plotext's log scale.
"""

from __future__ import annotations

import math

import numpy as np
from rich.text import Text
from textual.binding import Binding
from textual.message import Message
from textual_plotext import PlotextPlot
from textual_plotext.plot import Plot

from tui.figures.axes import nice_ticks
from tui.figures.data import Figure
from tui.figures.navigation import Navigation, xy_probe
from tui.keys import identified

COMPACT_ROWS = 24


class FigurePlot(PlotextPlot):
    """A plot drawn from a `Figure`.  `show` draws on the next render;
    `prebuild` (any thread) draws into text that `show` can hand over, so a
    worker thread can take the drawing off the UI thread.  Focused, it zooms,
    pans and moves a cursor along the current curve (`navigation`)."""

    can_focus = True
    BINDINGS = identified(
        "plot",
        [
            Binding(
                "plus,equals_sign", "zoom(1.5)", "zoom in", tooltip="zoom in (about the cursor)", id="plot.zoom_in"
            ),
            Binding("minus", "zoom(0.6666666666666666)", "zoom out", id="plot.zoom_out"),
            Binding(
                "left",
                "cursor(-1)",
                "cursor",
                id="plot.cursor_left",
                tooltip="the cursor along the curve (Poles: pole to pole, zeta, wn)",
            ),
            Binding("right", "cursor(1)", "cursor", show=False, id="plot.cursor_right"),
            Binding("shift+left", "cursor(-10)", "", show=False, id="plot.cursor_left_10"),
            Binding("shift+right", "cursor(10)", "", show=False, id="plot.cursor_right_10"),
            Binding("h", "pan(-0.25, 0)", "pan", tooltip="pan: h j k l", id="plot.pan_left"),
            Binding("l", "pan(0.25, 0)", "", show=False, id="plot.pan_right"),
            Binding("k", "pan(0, 0.25)", "", show=False, id="plot.pan_up"),
            Binding("j", "pan(0, -0.25)", "", show=False, id="plot.pan_down"),
            Binding("0", "reset_view", "reset", tooltip="the whole plot, no cursor"),
        ],
    )

    class Shown(Message):
        """The plot came on screen (its tab shown, the screen resumed): whatever it shows
        may be of an earlier design, so the screen checks it against the current one."""

        def __init__(self, plot: FigurePlot) -> None:
            super().__init__()
            self.plot = plot

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.figure = Figure()
        self.navigation = Navigation()
        self._prebuilt: tuple[tuple[int, int, str], Text] | None = None

    def action_zoom(self, factor: float) -> None:
        self.navigation.zoom(self.figure, factor)
        self.refresh()

    def action_pan(self, dx: float, dy: float) -> None:
        self.navigation.pan(self.figure, dx, dy)
        self.refresh()

    def action_cursor(self, step: int) -> None:
        self.navigation.move(self.figure, step)
        self.refresh()

    def action_reset_view(self) -> None:
        self.navigation.reset()
        self.refresh()

    def on_show(self) -> None:
        self.post_message(self.Shown(self))

    def on_mouse_scroll_up(self, event) -> None:
        self.action_zoom(1.25)

    def on_mouse_scroll_down(self, event) -> None:
        self.action_zoom(0.8)

    @property
    def shown(self) -> Figure:
        """The figure as drawn: zoomed, with the cursor (`navigation`)."""
        return self.navigation.applied(self.figure)

    def show(self, figure: Figure, prebuilt: tuple[tuple[int, int, str], Text] | None = None) -> None:
        if figure.probe is None:  # a cursor on any plot: along its first curve
            first = next((s for s in figure.series if s.x and not s.scatter), None)
            if first is not None:
                figure.probe = xy_probe(first, figure.xlabel or "x", figure.ylabel or "y")
        self.figure, self._prebuilt = figure, prebuilt
        self.refresh()

    def canvas(self) -> tuple[int, int, str]:
        """(width, height, plotext theme) of the next render."""
        return self.size.width, self.size.height, self._get_plotext_theme_name(self.app.theme)

    @staticmethod
    def prebuild(figure: Figure, canvas: tuple[int, int, str]) -> tuple[tuple[int, int, str], Text] | None:
        width, height, theme = canvas
        if width < 10 or height < 5:
            return None
        plot = Plot()
        _draw(plot, figure, height, width)
        plot.plotsize(width, height)
        plot._set_size(width, height)
        plot.theme(theme)
        try:
            return canvas, Text.from_ansi(plot.build())
        except (IndexError, ValueError, ZeroDivisionError, OverflowError):
            return None

    def render(self):
        figure = self.shown
        if self._prebuilt is not None and self._prebuilt[0] == self.canvas() and figure is self.figure:
            return self._prebuilt[1]
        _draw(self.plt, figure, self.size.height, self.size.width)
        try:
            return super().render()
        except (IndexError, ValueError, ZeroDivisionError, OverflowError) as exc:  # a tiny canvas, odd values
            return f"{self.figure.title}: cannot draw at this size ({type(exc).__name__})"


def _draw(plt, fig: Figure, height: int | None = None, width: int | None = None) -> None:
    """Clear ``plt`` and draw ``fig`` on it (its panels as subplots in one column; its compact
    variant when the canvas is shorter than COMPACT_ROWS; its title and x label cut to the
    ``width``)."""
    if fig.compact is not None and height is not None and height < COMPACT_ROWS:
        fig = fig.compact
    plt.clear_figure()
    if fig.panels:
        plt.subplots(len(fig.panels), 1)
        for row, panel in enumerate(fig.panels, start=1):
            _draw_one(plt.subplot(row, 1), panel, width)
        plt.main()
        return
    _draw_one(plt, fig, width)


def _draw_one(plt, fig: Figure, width: int | None = None) -> None:
    """Draw ``fig`` on a cleared plot or subplot (``width`` wide: the labels cut to fit)."""
    title, xlabel = fig.title or fig.empty_message, fig.xlabel
    if width is not None:
        title, xlabel = _fitted(fig, title, xlabel, width)
    plt.title(title)
    if xlabel:
        plt.xlabel(xlabel)
    if fig.ylabel:
        plt.ylabel(fig.ylabel)
    for s in fig.series:
        if not s.x:
            continue
        draw = plt.scatter if s.scatter else plt.plot
        kwargs = {"marker": s.marker, "label": (s.label or None) if _in_view(s, fig) else None}
        if s.color:
            kwargs["color"] = s.color
        draw(_near(s.x, fig.xlim), _near(s.y, fig.ylim), **kwargs)
    if fig.xlim:
        plt.xlim(*fig.xlim)
    if fig.ylim:
        plt.ylim(*fig.ylim)
    if fig.xticks is not None:  # ([], []): no time ticks (a panel above another)
        plt.xticks(*fig.xticks)
    elif (span := _span(fig, "x")) is not None:
        plt.xticks(*nice_ticks(*span))
    if fig.yticks:
        plt.yticks(*fig.yticks)
    elif (span := _span(fig, "y")) is not None:
        plt.yticks(*nice_ticks(*span))


def _in_view(series, fig: Figure) -> bool:
    """Has the series a point within the figure's limits?  plotext's legend indexes the
    colours of the points it kept, and fails (IndexError) for a labelled series it kept
    none of: zoomed in past a curve's samples, the plot read 'cannot draw at this size'."""
    x, y = np.asarray(series.x, dtype=float), np.asarray(series.y, dtype=float)
    inside = np.isfinite(x) & np.isfinite(y)
    for values, limits in ((x, fig.xlim), (y, fig.ylim)):
        if limits:
            inside &= (values >= min(limits)) & (values <= max(limits))
    return bool(inside.any())


def _fitted(fig: Figure, title: str, xlabel: str, width: int) -> tuple[str, str]:
    """The title and x label cut (with an ellipsis) to the room plotext gives them about the
    canvas centre (it drops a label that does not fit); the y tick labels' width estimated."""
    span = _span(fig, "y")
    labels = fig.yticks[1] if fig.yticks else nice_ticks(*span)[1] if span else []
    start = max((len(label) for label in labels), default=1) + 1
    centre = start + (width - start - 1) // 2
    right = width - centre
    room_title = 2 * right - 2
    room_x = min(2 * (centre - len(fig.ylabel) - 1), 2 * right) - 2

    def cut(text: str, room: int) -> str:
        return text if len(text) <= room else text[: max(room - 1, 0)].rstrip() + "…"

    return cut(title, room_title), cut(xlabel, room_x) if xlabel else xlabel


def _span(fig: Figure, axis: str) -> tuple[float, float] | None:
    """The axis's shown range: its limits, else the finite data's extent (None: no data)."""
    limits = fig.xlim if axis == "x" else fig.ylim
    if limits:
        return limits
    values = [v for s in fig.series for v in (s.x if axis == "x" else s.y) if math.isfinite(v) and abs(v) < PLOTTABLE]
    return (min(values), max(values)) if values and max(values) > min(values) else None


PLOTTABLE = 1e150  # plotext's arithmetic on the canvas overflows near the float limits


def _near(values: list[float], limits: tuple[float, float] | None) -> list[float]:
    """Values clipped to a few spans about the axis limits (plotext draws a line point by
    point across the canvas, so a point 1e23 spans off the axis would exhaust memory),
    and always to +-PLOTTABLE."""
    low, high = -PLOTTABLE, PLOTTABLE
    if limits and all(math.isfinite(v) for v in limits):
        span = max(abs(limits[1] - limits[0]), 1e-300)
        low, high = max(low, limits[0] - 2 * span), min(high, limits[1] + 2 * span)
    return np.clip(np.asarray(values, dtype=float), low, high).tolist()

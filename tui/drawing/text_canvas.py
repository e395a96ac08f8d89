"""A `Figure` drawn as text with plotext (the only module that touches plotext): its
panels one above the other, ticks spaced for the canvas, the legend in rows under the
plot (`tui.drawing.legend`), and where each panel's data area landed (`Frame`), so a
mouse cell can be read as a data point.

Each drawing starts from a cleared plotext figure (plotext's `build` rewrites stored
data, so a redraw from stored state could lie).  Log-frequency axes are drawn as
log10(omega) on a linear axis with decade labels, never with plotext's log scale."""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass, replace
from functools import cache
from itertools import groupby
from operator import itemgetter

import numpy as np
from plotext._utility import colors_to_ansi
from rich.ansi import AnsiDecoder
from rich.style import Style
from rich.text import Span as StyledRun
from rich.text import Text
from textual_plotext.plot import Plot

from tui.drawing import legend
from tui.drawing.text_layers import LAYERS, Drawn, Matrix, draw_series, layerable
from tui.figures.axes import nice_ticks, spaced
from tui.figures.data import Figure, Series

COMPACT_ROWS = 24  # a canvas shorter than this draws a figure's compact variant
ROOMY_ROWS = 18  # a canvas this tall or taller gives its legend two rows (one below: Bode's panels at 80x24)
PLOTTABLE = 1e150  # plotext's arithmetic on the canvas overflows near the float limits
LEGEND_ROWS = 2


Span = tuple[float, float] | None  # an axis's shown range (None: no data to show)
Spans = tuple[Span, Span]  # x, y


@dataclass(frozen=True)
class Frame:
    """Where a panel's data area is on the canvas (cells inside its frame) and the data
    limits it spans."""

    left: int
    right: int
    top: int
    bottom: int
    xlim: tuple[float, float]
    ylim: tuple[float, float]

    def contains(self, col: int, row: int) -> bool:
        return self.left <= col <= self.right and self.top <= row <= self.bottom

    def point(self, col: float, row: float) -> tuple[float, float]:
        """The data point at a cell's centre."""
        fx = (col - self.left) / max(self.right - self.left, 1)
        fy = (self.bottom - row) / max(self.bottom - self.top, 1)
        (x0, x1), (y0, y1) = self.xlim, self.ylim
        return x0 + fx * (x1 - x0), y0 + fy * (y1 - y0)

    def cells(self, x: float, y: float) -> tuple[float, float]:
        """The (column, row) of a data point (fractional)."""
        (x0, x1), (y0, y1) = self.xlim, self.ylim
        col = self.left + (x - x0) / ((x1 - x0) or 1.0) * (self.right - self.left)
        row = self.bottom - (y - y0) / ((y1 - y0) or 1.0) * (self.bottom - self.top)
        return col, row


@dataclass(frozen=True)
class Drawing:
    text: Text
    frames: tuple[Frame, ...]
    legend_rows: int = 0  # the last rows of the text: the legend, under the plot


def draw(figure: Figure, width: int, height: int, theme: str) -> Drawing | None:
    """The figure drawn on a ``width`` x ``height`` canvas (None: too small, or plotext
    failed on its values)."""
    if width < 10 or height < 5:
        return None
    if figure.compact is not None and height < COMPACT_ROWS:
        figure = figure.compact
    legend_rows = legend.rows(legend.entries(figure), width, LEGEND_ROWS if height >= ROOMY_ROWS else 1)
    plot_height = height - len(legend_rows)
    if plot_height < 5:
        legend_rows, plot_height = [], height
    panels = figure.panels or [figure]
    spans = [_spans(panel) for panel in panels]
    try:
        text = layered_text(figure, spans[0], width, plot_height, theme) if not figure.panels else None
        if text is None:
            text = canvas_text(_plotted(figure, spans, width, plot_height, theme))
    except (IndexError, ValueError, ZeroDivisionError, OverflowError):
        return None
    if legend_rows and text.plain.endswith("\n"):
        text.right_crop(1)  # plotext ends its last row with a newline
    for row in legend_rows:
        text.append("\n")
        text.append_text(row)
    return Drawing(text, frames(text.plain, spans), len(legend_rows))


def _plotted(figure: Figure, spans: list[Spans], width: int, height: int, theme: str) -> Plot:
    """A plotext plot of the figure at a canvas, not built yet."""
    plot = Plot()
    _draw(plot, figure, spans, height, width)
    _fit(plot, width, height, theme)
    return plot


def _fit(plot: Plot, width: int, height: int, theme: str) -> None:
    """The plot's size and theme (set after its series: they take their colours from the
    default theme's sequence, as they always have here)."""
    plot.plotsize(width, height)
    plot._set_size(width, height)
    plot.theme(theme)


def layered_text(figure: Figure, spans: Spans, width: int, height: int, theme: str) -> Text | None:
    """The figure's text: its series drawn over its static layer (frame, axes, ticks, labels)
    kept for this canvas and view (`text_layers`); None: to be drawn whole (no view to key the
    layer by, no series, or a series only plotext draws)."""
    ordered = [s for s in sorted(figure.series, key=lambda s: not s.beneath) if s.x]
    if spans[0] is None or spans[1] is None or not ordered:
        return None
    drawn = tuple(_as_drawn(s, spans, width) for s in ordered)
    if not all(map(layerable, drawn)):
        return None
    matrix = LAYERS.static(
        _frame_key(figure, spans, width, height, theme), lambda: _static(figure, spans, width, height, theme)
    )
    if matrix.cols <= 0 or matrix.rows <= 0:
        return None
    draw_series(matrix, drawn)
    return matrix_text(matrix.marker, matrix.fullground, matrix.style, matrix.background)


def _static(figure: Figure, spans: Spans, width: int, height: int, theme: str) -> Matrix:
    """Plotext's matrices of the figure without its series (the colours they will take: from
    the default theme's sequence, as when drawn whole)."""
    plot = Plot()
    _draw(plot, replace(figure, series=[]), [spans], height, width)
    colours = (tuple(plot.monitor.color_sequence), list(plot.monitor.past_colors))
    plot.plot([], [])  # a series: plotext draws the axes of a plot that has one
    _fit(plot, width, height, theme)
    return _built_matrix(plot, colours)


def _frame_key(figure: Figure, spans: Spans, width: int, height: int, theme: str) -> Hashable:
    """What a figure's static layer depends on besides its series: the canvas, the view and
    what `_draw_one` writes."""
    ticks = tuple(None if t is None else (tuple(t[0]), tuple(t[1])) for t in (figure.xticks, figure.yticks))
    return (width, height, theme, spans, figure.title or figure.empty_message, figure.xlabel, figure.ylabel, ticks)


def _as_drawn(series: Series, spans: Spans, width: int) -> Drawn:
    x, y = _points(series, spans, width)
    return tuple(x), tuple(y), series.marker, series.scatter, series.color or None


def _built_matrix(plot: Plot, colours: tuple[tuple, list]) -> Matrix:
    """The plot built: plotext's matrices, where its data area landed, and the ``colours``
    of its series (`Matrix.sequence`, `Matrix.used`)."""
    plot._set_sizes()
    plot._build_matrix()
    m, monitor = plot.monitor.matrix, plot.monitor
    xlim, ylim = monitor.xlim[0], monitor.ylim[0]
    cols, rows = m.Cols_canvas, m.Rows_canvas
    place = (cols.start, rows.start, len(cols), len(rows), (xlim[0], xlim[1]), (ylim[0], ylim[1]))
    return Matrix(m.marker, m.fullground, m.style, m.background, *place, *colours)


def canvas_text(plot: Plot) -> Text:
    """The plot built and read off plotext's matrices of characters and colours (its canvas
    keeps them: `monitor.matrix`): the text `Text.from_ansi(plot.build())` gives, with no
    escape codes written and parsed (a third of plotext's drawing)."""
    plot._set_sizes()
    plot._build_matrix()
    m = plot.monitor.matrix
    return matrix_text(m.marker, m.fullground, m.style, m.background)


def matrix_text(marker: list[list[str]], fullground: list, styles: list, background: list) -> Text:
    """Plotext's matrices (rows from the bottom) as text: each row a run of equal colours at a
    time, each run one span of the style rich reads from plotext's codes for those colours
    (`_run_style`), a newline after each row."""
    parts: list[str] = []
    spans: list[StyledRun] = []
    offset = 0
    for row in reversed(range(len(marker))):
        colours = zip(fullground[row], styles[row], background[row])
        for colour, run in groupby(zip(marker[row], colours), key=itemgetter(1)):
            chunk = "".join(char for char, _ in run)
            style = _run_style(colors_to_ansi(*colour))
            if style is not None:
                spans.append(StyledRun(offset, offset + len(chunk), style))
            parts.append(chunk)
            offset += len(chunk)
        parts.append("\n")
        offset += 1
    return Text("".join(parts), end="\n", tab_size=8, spans=spans)


@cache
def _run_style(code: str) -> Style | None:
    """The style rich reads from plotext's escape codes for a run's colours (None: none)."""
    spans = AnsiDecoder().decode_line(code + " ").spans
    style = spans[0].style if spans else None
    return style if isinstance(style, Style) else None


def frames(plain: str, spans: list[Spans]) -> tuple[Frame, ...]:
    """The panels' data areas (their ``spans``, in order), found by their frames' corners
    in the drawn text."""
    lines = plain.split("\n")
    found = []
    for row, line in enumerate(lines):
        col = line.find("┌")
        end = line.find("┐", col + 1)
        if col < 0 or end < 0:
            continue
        bottom = next((r for r in range(row + 1, len(lines)) if lines[r][col : col + 1] == "└"), None)
        if bottom is not None and len(found) < len(spans):
            x, y = spans[len(found)]
            found.append(Frame(col + 1, end - 1, row + 1, bottom - 1, x or (0.0, 1.0), y or (0.0, 1.0)))
    return tuple(found)


def _draw(plt, fig: Figure, spans: list[Spans], height: int, width: int) -> None:
    """Draw ``fig`` on a new plot ``plt`` (its panels as subplots in one column; a new plot is
    cleared: plotext's `clear_figure` makes it anew, a deep copy of its defaults)."""
    if fig.panels:
        plt.subplots(len(fig.panels), 1)
        for row, (panel, panel_spans) in enumerate(zip(fig.panels, spans), start=1):
            _draw_one(plt.subplot(row, 1), panel, panel_spans, width, height // len(fig.panels))
        plt.main()
        return
    _draw_one(plt, fig, spans[0], width, height)


def _draw_one(plt, fig: Figure, spans: Spans, width: int, height: int) -> None:
    """Draw ``fig`` on a cleared plot or subplot ``width`` x ``height`` over its axes'
    ``spans`` (the labels cut to fit, the ticks spaced; no legend: it is under the plot)."""
    xspan, yspan = spans
    title, xlabel = _fitted(fig, yspan, fig.title or fig.empty_message, fig.xlabel, width)
    plt.title(title)
    if xlabel:
        plt.xlabel(xlabel)
    if fig.ylabel:
        plt.ylabel(fig.ylabel)
    for s in sorted(fig.series, key=lambda s: not s.beneath):
        if not s.x:
            continue
        draw = plt.scatter if s.scatter else plt.plot
        kwargs = {"marker": s.marker}
        if s.color:
            kwargs["color"] = s.color
        draw(*_points(s, spans, width), **kwargs)
    for limits, set_limits in ((xspan, plt.xlim), (yspan, plt.ylim)):
        if limits is not None:
            set_limits(*limits)
    rows = height - 3 - bool(fig.xlabel) - (fig.xticks is None or bool(fig.xticks[0]))  # title, frame, x labels
    for axis, span, given, ticks_of in (("x", xspan, fig.xticks, plt.xticks), ("y", yspan, fig.yticks, plt.yticks)):
        ticks = given if given is not None else nice_ticks(*span) if span is not None else None
        if ticks is None:
            continue
        if span is not None and ticks[0]:
            cells = rows if axis == "y" else width - _label_width(fig, yspan) - 2
            ticks = spaced(list(ticks[0]), list(ticks[1]), span, cells, axis)
        ticks_of(*ticks)


def _points(series: Series, spans: Spans, width: int) -> tuple[list[float], list[float]]:
    """A series' points as plotext gets them: a line thinned to the canvas's columns, every
    value clipped near the view (`near`)."""
    xspan, yspan = spans
    x, y = series.x, series.y
    if not series.scatter and xspan is not None:
        x, y = thinned(x, y, xspan, 2 * width)
    return near(x, xspan), near(y, yspan)


def _label_width(fig: Figure, yspan: Span) -> int:
    labels = fig.yticks[1] if fig.yticks else nice_ticks(*yspan)[1] if yspan else []
    return max((len(label) for label in labels), default=1) + 1


def _fitted(fig: Figure, yspan: Span, title: str, xlabel: str, width: int) -> tuple[str, str]:
    """The title and x label cut (with an ellipsis) to the room plotext gives them about the
    canvas centre (it drops a label that does not fit); the y tick labels' width estimated."""
    start = _label_width(fig, yspan)
    centre = start + (width - start - 1) // 2
    right = width - centre
    room_title = 2 * right - 2
    room_x = min(2 * (centre - len(fig.ylabel) - 1), 2 * right) - 2

    def cut(text: str, room: int) -> str:
        return text if len(text) <= room else text[: max(room - 1, 0)].rstrip() + "…"

    return cut(title, room_title), cut(xlabel, room_x) if xlabel else xlabel


def _spans(fig: Figure) -> Spans:
    """The axes' shown ranges (`span_of`) of a figure."""
    return span_of(fig.xlim, [s.x for s in fig.series]), span_of(fig.ylim, [s.y for s in fig.series])


def span_of(limits: Span, series: list[list[float]]) -> Span:
    """An axis's shown range: its limits, else the finite data's extent, widened about a
    constant (None: no data)."""
    if limits:
        return limits
    values = np.concatenate([np.asarray(v, dtype=float) for v in series]) if series else np.empty(0)
    values = values[np.isfinite(values) & (np.abs(values) < PLOTTABLE)]
    if not values.size:
        return None
    low, high = float(values.min()), float(values.max())
    if high > low:
        return low, high
    room = abs(low) * 0.1 or 1.0
    return low - room, high + room


def thinned(x: list[float], y: list[float], xspan: tuple[float, float], columns: int) -> tuple[list, list]:
    """A line's points as the canvas resolves them: within each run of consecutive points
    in one of ``columns`` pixel columns over ``xspan``, the first, the lowest, the highest
    and the last (in order): plotext draws fewer segments (a 600-point Bode on 140 braille
    columns: about half) and the line lands within a dot of the whole one's."""
    n = len(x)
    if n <= 2 * columns:
        return x, y
    xs, ys = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    x0, x1 = xspan
    with np.errstate(invalid="ignore", over="ignore"):
        column = np.floor((xs - x0) / ((x1 - x0) or 1.0) * columns)
    column = np.where(np.isfinite(column) & np.isfinite(ys), column, np.nan)
    starts = np.flatnonzero(
        np.r_[True, ~((column[1:] == column[:-1]) | (np.isnan(column[1:]) & np.isnan(column[:-1])))]
    )
    run = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, n]))
    order = np.lexsort((np.where(np.isfinite(ys), ys, 0.0), run))  # by run, then y
    ends = np.r_[starts[1:], n] - 1
    lowest, highest = order[starts], order[ends]
    keep = np.unique(np.concatenate([starts, ends, lowest, highest]))
    return xs[keep].tolist(), ys[keep].tolist()


def near(values: list[float], limits: tuple[float, float] | None) -> list[float]:
    """Values clipped to a few spans about the axis limits (plotext draws a line point by
    point across the canvas, so a point 1e23 spans off the axis would exhaust memory),
    and always to +-PLOTTABLE."""
    low, high = -PLOTTABLE, PLOTTABLE
    if limits and all(math.isfinite(v) for v in limits):
        span = max(abs(limits[1] - limits[0]), 1e-300)
        low, high = max(low, limits[0] - 2 * span), min(high, limits[1] + 2 * span)
    return np.clip(np.asarray(values, dtype=float), low, high).tolist()

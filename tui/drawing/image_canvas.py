"""A `Figure` drawn as an image with matplotlib (Agg, no pyplot: safe off the UI thread)
for terminals that show images (`tui.drawing.graphics`): the same figure as the text
canvas draws, at the widget's pixel size, the legend under the axes, and where each
panel's data area landed in cells (`Frame`, for the mouse)."""

from __future__ import annotations

import math

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure as MplFigure
from PIL import Image

from tui.drawing.text_canvas import COMPACT_ROWS, Frame, span_of
from tui.figures.data import Figure, Series

LINE_STYLES = {"braille": "-", "·": ":", "dot": "--", "∙": ":", "~": "-.", "=": "--", "*": "-.", "+": ":", "#": "--"}
SCATTER_MARKERS = {"x": "x", "o": "o", "+": "+", "*": "*", "|": "|", "░": "s"}
DARK = {"face": "#1e1e1e", "ink": "#e0e0e0", "grid": "#444444", "blue": "#6cb6ff", "gray": "#999999"}
LIGHT = {"face": "#ffffff", "ink": "#202020", "grid": "#cccccc", "blue": "#1f5fbf", "gray": "#888888"}
DPI = 100


def face(dark: bool) -> str:
    """The background colour of a drawing (the widget paints it where the image is not)."""
    return (DARK if dark else LIGHT)["face"]


def draw(
    figure: Figure, cells: tuple[int, int], cell: tuple[int, int], dark: bool
) -> tuple[Image.Image, tuple[Frame, ...]]:
    """The figure as an image ``cells`` (columns, rows) of ``cell`` pixels, and its panels'
    data areas in cells."""
    if figure.compact is not None and cells[1] < COMPACT_ROWS:
        figure = figure.compact
    width, height = cells[0] * cell[0], cells[1] * cell[1]
    colors = DARK if dark else LIGHT
    mpl = MplFigure(figsize=(width / DPI, height / DPI), dpi=DPI, facecolor=colors["face"])
    panels = figure.panels or [figure]
    axes = mpl.subplots(len(panels), 1, squeeze=False)[:, 0]
    handles = {}
    for ax, panel in zip(axes, panels):
        _panel(ax, panel, colors, handles)
    if handles and figure.legend:
        columns = max(1, min(len(handles), width // 210))
        mpl.legend(
            handles.values(),
            handles.keys(),
            loc="lower center",
            ncol=columns,
            fontsize="x-small",
            frameon=False,
            labelcolor=colors["ink"],
        )
        rows = math.ceil(len(handles) / columns)
        mpl.tight_layout(rect=(0, min(rows * 16 / height, 0.4), 1, 1))  # the legend's rows under the axes
    else:
        mpl.tight_layout()
    canvas = FigureCanvasAgg(mpl)
    canvas.draw()
    image = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba()).convert("RGB")
    frames = tuple(_frame(ax, height, cell) for ax in axes)
    return image, frames


def _panel(ax, fig: Figure, colors: dict, handles: dict) -> None:
    """One panel: its series (references beneath), limits, ticks, labels."""
    ax.set_facecolor(colors["face"])
    for spine in ax.spines.values():
        spine.set_color(colors["ink"])
    ax.tick_params(colors=colors["ink"], labelsize="small")
    ax.set_title(fig.title or fig.empty_message, color=colors["ink"], fontsize="small")
    ax.set_xlabel(fig.xlabel, color=colors["ink"], fontsize="small")
    ax.set_ylabel(fig.ylabel, color=colors["ink"], fontsize="small")
    ax.grid(True, color=colors["grid"], linewidth=0.5)
    for s in sorted(fig.series, key=lambda s: not s.beneath):
        if s.x:
            artist = _series(ax, s, colors)
            if s.label and s.label not in handles:
                handles[s.label] = artist
    xspan, yspan = span_of(fig.xlim, [s.x for s in fig.series]), span_of(fig.ylim, [s.y for s in fig.series])
    if xspan:
        ax.set_xlim(*xspan)
    if yspan:
        ax.set_ylim(*yspan)
    if fig.xticks is not None:
        ax.set_xticks(fig.xticks[0], fig.xticks[1])
    if fig.yticks is not None:
        ax.set_yticks(fig.yticks[0], fig.yticks[1])


def _series(ax, s: Series, colors: dict):
    color = colors.get(s.color or "blue", s.color)
    if s.scatter:
        marker = SCATTER_MARKERS.get(s.marker, "o")
        alpha = 0.25 if s.marker == "░" else 1.0
        return ax.scatter(s.x, s.y, marker=marker, color=color, s=16, alpha=alpha, zorder=1 if s.beneath else 3)
    style = LINE_STYLES.get(s.marker, "-")
    width = 1.6 if s.marker in ("─", "│", "═", "╲", "╱") else 1.0
    (line,) = ax.plot(s.x, s.y, linestyle=style, color=color, linewidth=width, zorder=1 if s.beneath else 2)
    return line


def _frame(ax, height: int, cell: tuple[int, int]) -> Frame:
    """An axes' data area in cells (rows counted from the top) and its limits."""
    box = ax.get_window_extent()
    left, right = box.x0 / cell[0], box.x1 / cell[0]
    top, bottom = (height - box.y1) / cell[1], (height - box.y0) / cell[1]
    return Frame(round(left), round(right), round(top), round(bottom), tuple(ax.get_xlim()), tuple(ax.get_ylim()))

"""A figure's text drawn in two layers (issue 55, section 2: a drag frame's time was plotext
drawing the whole plot again): the static layer, plotext's matrices of characters and colours
for the frame, axes, ticks and labels, kept per canvas and view (`Layers`); and the series
drawn over a copy of it, rasterized here as plotext rasterizes a series (its mapping to the
canvas, its lines between points, its braille dots and glyphs, its colour for a series
without one: `Matrix.colour`), so the text is the one plotext draws for the whole figure
(`tests/tui/test_text_layers.py` checks it cell by cell).

Plotext draws every series after the axes, grid and labels, each over the ones before and
each from its own points alone, so the matrix of a figure is the matrix of its frame with the
series drawn over it in order.  A drag frame (the view held) draws its series over the layer
kept; a nudge (the view follows the data) builds the frame alone with plotext, a quarter of
its whole drawing.  The series drawn here need a braille or one-character marker (plotext's
`hd` markers are drawn otherwise): a figure with one of those is drawn whole by plotext."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass

import numpy as np
from plotext._dict import braille_codes, marker_codes
from plotext._utility import is_color, no_color

from engine.derived import Derived, Form

BRAILLE = "braille"
KEPT_FRAMES = 8  # static layers kept (a plot's canvas and view each; the least recently used dropped first)
# a braille cell's glyph by its 8 dots as a bit mask: bit (3 - row) * 2 + column, plotext's order
_BRAILLE_GLYPHS = tuple(braille_codes[tuple((mask >> bit) & 1 for bit in range(8))] for mask in range(256))

Drawn = tuple[tuple[float, ...], tuple[float, ...], str, bool, str | None]  # a series as plotext gets it


@dataclass(frozen=True)
class Matrix:
    """Plotext's matrices of a drawn canvas (rows from the bottom, as plotext keeps them),
    where its data area is (``cols`` x ``rows`` cells from (``col``, ``row``), over the data
    limits ``xlim``, ``ylim``), and the colours its series took (``used``, in order) from its
    theme's sequence when it was drawn (``sequence``)."""

    marker: list[list[str]]
    fullground: list[list[object]]
    style: list[list[str]]
    background: list[list[object]]
    col: int
    row: int
    cols: int
    rows: int
    xlim: tuple[float, float]
    ylim: tuple[float, float]
    sequence: tuple[object, ...]
    used: list[object]

    def copy(self) -> Matrix:
        """A copy whose characters and colours can be drawn over (the background is never written)."""
        rows = (self.marker, self.fullground, self.style)
        marker, fullground, style = ([row[:] for row in m] for m in rows)
        place = (self.col, self.row, self.cols, self.rows, self.xlim, self.ylim, self.sequence)
        return Matrix(marker, fullground, style, self.background, *place, list(self.used))

    def colour(self, given: str | None) -> object:
        """The colour plotext draws the next series in (its `check_color`): the one given when
        plotext knows it, else the first of the theme's sequence no series took yet."""
        colour = given if given is not None and is_color(given) else None
        if colour is None:
            free = [c for c in self.sequence if c not in self.used]
            colour = free[0] if free else self.sequence[0]
        if colour not in self.used:
            self.used.append(colour)
        return colour


def plotext_marker(marker: str) -> str:
    """The marker plotext draws for a series' marker name (its `check_marker`)."""
    marker = marker_codes.get(marker, marker)
    return marker if marker in ("hd", "fhd", BRAILLE) else marker[:1]


def layerable(drawn: Drawn) -> bool:
    """Can a series be drawn here exactly as plotext draws it (a braille or one-character marker)?"""
    return plotext_marker(drawn[2]) not in ("hd", "fhd", "")


def draw_series(matrix: Matrix, drawn: Sequence[Drawn]) -> None:
    """Draw series over ``matrix`` in order, as plotext's `build_plot` does."""
    for x, y, marker, scatter, given in drawn:
        glyph, color = plotext_marker(marker), matrix.colour(given)
        for col, row, char in _cells(x, y, glyph, not scatter, matrix):
            matrix.marker[matrix.row + row][matrix.col + col] = char
            matrix.fullground[matrix.row + row][matrix.col + col] = color
            matrix.style[matrix.row + row][matrix.col + col] = no_color


def _cells(
    x: Sequence[float], y: Sequence[float], glyph: str, lines: bool, matrix: Matrix
) -> list[tuple[int, int, str]]:
    """The cells a series marks inside the data area and the character of each: its points
    mapped to the canvas (`get_matrix_data`: braille has 2 x 4 dots a cell), joined by
    plotext's lines (`_joined`), grouped into braille cells (a dot each) or one glyph a cell."""
    across, up = (2, 4) if glyph == BRAILLE else (1, 1)
    px = canvas_points(x, matrix.xlim, matrix.cols * across)
    py = canvas_points(y, matrix.ylim, matrix.rows * up)
    if lines and px.size:
        px, py = _joined(px, py)
    kept = np.isfinite(px) & np.isfinite(py)
    px, py = px[kept].astype(np.int64), py[kept].astype(np.int64)
    col, row = px // across, py // up
    inside = (col >= 0) & (col < matrix.cols) & (row >= 0) & (row < matrix.rows)
    col, row, px, py = col[inside], row[inside], px[inside], py[inside]
    cell = row * matrix.cols + col
    if glyph != BRAILLE:
        return [(int(c) % matrix.cols, int(c) // matrix.cols, glyph) for c in np.unique(cell)]
    dots = np.zeros(matrix.rows * matrix.cols, dtype=np.int64)
    np.bitwise_or.at(dots, cell, 1 << ((3 - py % 4) * 2 + px % 2))
    marked = np.flatnonzero(dots)
    return [(int(c) % matrix.cols, int(c) // matrix.cols, _BRAILLE_GLYPHS[dots[c]]) for c in marked]


def canvas_points(values: Sequence[float], limits: tuple[float, float], bins: int) -> np.ndarray:
    """Plotext's `get_matrix_data` on arrays, the same operations in the same order (its
    `round` to 8 digits rounds a half up, then `floor`); a missing value stays NaN, an
    infinite one and empty limits raise as plotext does."""
    v = np.asarray(values, dtype=float)
    if np.isinf(v).any():
        raise OverflowError("cannot convert float infinity to integer")
    if limits[1] == limits[0]:
        raise ZeroDivisionError("float division by zero")
    n = (0.5 + (bins - 1) * (v - limits[0]) / (limits[1] - limits[0])) * 100000000
    f = np.floor(n)
    return np.floor(np.where(n - f < 0.5, f, np.ceil(n)) * 1e-08)


def _joined(px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plotext's `get_lines` on canvas points: each pair of neighbours joined by max(|dx|,
    |dy|) + 1 points of `linspace` (each truncated by `int`), the last left to the next pair;
    a pair with a missing point keeps its first point alone; then the last point."""
    x0, x1, y0, y1 = px[:-1], px[1:], py[:-1], py[1:]
    whole = np.isfinite(x0) & np.isfinite(x1) & np.isfinite(y0) & np.isfinite(y1)
    with np.errstate(invalid="ignore"):
        steps = np.where(whole, np.maximum(np.abs(x1 - x0), np.abs(y1 - y0)), 1.0).astype(np.int64)
        slope_x = np.where(whole & (steps > 0), (x1 - x0) / np.maximum(steps, 1), 0.0)
        slope_y = np.where(whole & (steps > 0), (y1 - y0) / np.maximum(steps, 1), 0.0)
    pair = np.repeat(np.arange(x0.size), steps)
    k = np.arange(pair.size) - np.repeat(np.cumsum(steps) - steps, steps)
    lx = np.where(whole[pair], np.trunc(x0[pair] + k * slope_x[pair]), x0[pair])
    ly = np.where(whole[pair], np.trunc(y0[pair] + k * slope_y[pair]), y0[pair])
    return np.r_[lx, px[-1:]], np.r_[ly, py[-1:]]


_FRAME: Form[Matrix] = Form("a canvas and view's static layer")


class Layers:
    """The static layers kept, by frame key (canvas, theme, view, labels, ticks), the ``kept``
    used last (`engine.derived.Derived`); any thread (the figures are drawn in workers)."""

    def __init__(self, kept: int = KEPT_FRAMES) -> None:
        self._frames = Derived(kept)
        self.builds = 0  # static layers built (a test counts them)

    def static(self, key: Hashable, build: Callable[[], Matrix]) -> Matrix:
        """A copy, to draw over, of the frame's static layer (built by ``build`` when not kept)."""

        def built() -> Matrix:
            self.builds += 1
            return build()

        return self._frames.get(_FRAME, built, key).copy()


LAYERS = Layers()

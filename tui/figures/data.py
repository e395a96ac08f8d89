"""A plot's data: its series, limits, ticks and, for a cursor, its probe."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Series:
    x: list[float]
    y: list[float]
    label: str = ""
    marker: str = "braille"
    scatter: bool = False
    color: str | None = None
    beneath: bool = False  # drawn under the other series (a reference, a guide, a shaded region): it never hides them


@dataclass(frozen=True)
class Handle:
    """A mark the mouse drags (`FigurePlot`): a compensator item's (``name``: block.item)
    at (x, y) as drawn, or a point of the figure's curve (``name`` ""); ``motion`` says what
    the pointer sets: "root" (the item's root: a real one along the axis, a pair's upper
    root), "corner" (the item's frequency: x is log10 of it), "gain" (the loop gain: the dB
    the pointer moved up or down), "locus" (the loop gain at the nearest locus point)."""

    x: float
    y: float
    name: str
    motion: str


@dataclass
class Figure:
    title: str = ""
    xlabel: str = ""
    ylabel: str = ""
    xlim: tuple[float, float] | None = None
    ylim: tuple[float, float] | None = None
    xticks: tuple[list[float], list[str]] | None = None
    yticks: tuple[list[float], list[str]] | None = None
    series: list[Series] = field(default_factory=list)
    empty_message: str = ""
    panels: list[Figure] = field(default_factory=list)  # drawn one above the other instead of `series`
    compact: Figure | None = None  # drawn instead on a canvas of fewer than COMPACT_ROWS rows
    probe: Any = None  # a `navigation.Probe`: where a cursor moves and what it reads
    log_x: bool = False  # x is log10 of a frequency: zoomed ticks are labelled as frequencies
    legend: bool = True  # False: another plot beside it carries the same legend (Bode phase under magnitude)
    handles: list[Handle] = field(default_factory=list)  # the marks the mouse drags (compensator items)
    curve_motion: str = ""  # what dragging the probe's curve sets ("gain", "locus"; "": a press there pans)


def in_view(series: Series, fig: Figure) -> bool:
    """Has the series a finite point within the figure's limits?"""
    x, y = np.asarray(series.x, dtype=float), np.asarray(series.y, dtype=float)
    inside = np.isfinite(x) & np.isfinite(y)
    for values, limits in ((x, fig.xlim), (y, fig.ylim)):
        if limits:
            inside &= (values >= min(limits)) & (values <= max(limits))
    return bool(inside.any())


CONDITION_COLORS = ("blue", "orange", "magenta", "cyan", "green", "yellow", "red")
REFERENCE_COLOR = "gray"


CONDITION_MARKERS = ("braille", "dot", "*", "+", "~", "=", "#")
REFERENCE_MARKER = "·"


def role_style(role: str, index: int = 0) -> dict:
    """The colour and line style of a curve of a role (`role_color`): the current design a
    fine braille line, a reference a dotted one, each condition its own marker, so the
    curves are told apart without colour (a monochrome terminal, an SVG, a colour-blind eye)."""
    if role == "reference":
        return {"color": role_color(role, index), "marker": REFERENCE_MARKER, "beneath": True}
    if role == "condition":
        marker = CONDITION_MARKERS[index % len(CONDITION_MARKERS)]
    else:
        marker = "braille"
    return {"color": role_color(role, index), "marker": marker}


def role_color(role: str, index: int = 0) -> str:
    """The colour a curve of a role is drawn in (`engine.analysis.LoopCurve`'s roles): the
    current design blue, a reference (initial or earlier design) gray, the ``index``-th of
    several conditions its own."""
    if role == "reference":
        return REFERENCE_COLOR
    if role == "condition":
        return CONDITION_COLORS[index % len(CONDITION_COLORS)]
    return "blue"

"""A plot's data: its series, limits, ticks and, for a cursor, its probe."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class Series:
    x: list[float]
    y: list[float]
    label: str = ""
    marker: str = "braille"
    scatter: bool = False
    color: str | None = None


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


CONDITION_COLORS = ("blue", "orange", "magenta", "cyan", "green", "yellow", "red")
REFERENCE_COLOR = "gray"


def role_color(role: str, index: int = 0) -> str:
    """The colour a curve of a role is drawn in (`engine.analysis.LoopCurve`'s roles): the
    current design blue, a reference (initial or earlier design) gray, the ``index``-th of
    several conditions its own."""
    if role == "reference":
        return REFERENCE_COLOR
    if role == "condition":
        return CONDITION_COLORS[index % len(CONDITION_COLORS)]
    return "blue"

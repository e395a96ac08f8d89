"""Zoom, pan and a cursor on a plot, as plain state (no drawing here).

A plot's `Navigation` holds the shown box (None: the figure's own limits or
its data's), the cursor's index along the figure's `Probe` and makes the
figure to draw: the box as its limits, the cursor as a marked point, the
point's readout as the title.  Axes are linear in what is drawn (a log
frequency axis is drawn as log10 of the frequency), so zooming keeps a
log axis correct."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from tui.figures.data import Figure, Handle, Series

Box = tuple[float, float, float, float]  # x0, x1, y0, y1
ZOOM = 1.5
PAN = 0.25
LIMIT = 1e300  # a zoomed or panned box stays within +-LIMIT (its size and ticks stay finite)
GRAB_CELLS = 2.0  # a press this near (in cells) a handle or a draggable curve grabs it
LOG_LIMIT = 300.0  # on a log10 axis (log_x): 1e-300 to 1e300, powers of ten a float holds


@dataclass(frozen=True)
class Probe:
    """The points a cursor moves along (the current design's curve) and what it says at each."""

    x: list[float]
    y: list[float]
    readout: Callable[[int], str]
    start: int | None = None  # where the cursor appears (None: the middle point)
    chosen: Callable[[int], object] | None = None  # what enter on a point picks (a locus: the gain there)


def loop_probe(x, y, omega, gh, unit: str, branch: Callable[[float, float], float] | None = None) -> Probe:
    """A probe on an open-loop curve: frequency (in ``unit``), gain (dB), phase (deg) and the
    point; the phase on the branch the phase axis draws (``branch``: the curve's
    `LoopCurve.on_branch`, the one rule of the marks and lines), else in (-180, 180]."""
    scale = 2 * math.pi if unit == "hz" else 1.0
    omega, gh = np.asarray(omega, dtype=float), np.asarray(gh, dtype=complex)

    def readout(i: int) -> str:
        g = gh[i]
        db = 20 * math.log10(abs(g)) if g != 0 else -math.inf
        angle = math.degrees(np.angle(g))
        phase = angle if branch is None else branch(angle, float(omega[i]))
        return (
            f"w = {omega[i] / scale:.6g} {unit}  |GH| = {db:.4f} dB  phase = {phase:.3f} deg"
            f"  GH = {g.real:.5g}{g.imag:+.5g}j"
        )

    return Probe(list(map(float, x)), list(map(float, y)), readout)


def xy_probe(series: Series, xname: str = "x", yname: str = "y") -> Probe:
    """A probe on any series: its coordinates."""
    return Probe(series.x, series.y, lambda i: f"{xname} = {series.x[i]:.6g}  {yname} = {series.y[i]:.6g}")


@dataclass
class Navigation:
    box: Box | None = None
    cursor: int | None = None
    picked: Probe | None = None  # the curve a click put the cursor on (None: the figure's probe)

    def reset(self) -> None:
        self.box, self.cursor, self.picked = None, None, None

    def forget_pick(self) -> None:
        """A new figure: a picked curve is of the old one (the cursor goes with it)."""
        if self.picked is not None:
            self.picked, self.cursor = None, None

    def follow(self, figure: Figure, leader: Navigation) -> None:
        """Take another panel's frequency range and cursor (Bode's magnitude and phase share
        their x axis): its box's x limits with this figure's own y range, its cursor when it
        runs along the figure's probe (a curve picked by a click is that panel's own)."""
        if leader.box is None:
            self.box = None
        else:
            y0, y1 = (self.box or data_box(figure))[2:]
            self.box = (leader.box[0], leader.box[1], y0, y1)
        if leader.picked is None:
            self.cursor, self.picked = leader.cursor, None

    def probe(self, figure: Figure) -> Probe | None:
        return self.picked or figure.probe

    def zoom(self, figure: Figure, factor: float) -> None:
        """Zoom about the cursor (else the box's centre): factor > 1 zooms in."""
        x0, x1, y0, y1 = self.box or data_box(figure)
        about = self._point(figure) or ((x0 + x1) / 2, (y0 + y1) / 2)
        self.zoom_at(figure, factor, about)

    def zoom_at(self, figure: Figure, factor: float, about: tuple[float, float]) -> None:
        """Zoom keeping the data point ``about`` where it is (the mouse wheel's pointer)."""
        x0, x1, y0, y1 = self.box or data_box(figure)
        cx, cy = about
        box = (cx - (cx - x0) / factor, cx + (x1 - cx) / factor, cy - (cy - y0) / factor, cy + (y1 - cy) / factor)
        if _showable(box, figure.log_x):
            self.box = box

    def pan(self, figure: Figure, dx: float, dy: float) -> None:
        """Move the box by fractions of its size."""
        x0, x1, y0, y1 = self.box or data_box(figure)
        self.shift(figure, (x1 - x0) * dx, (y1 - y0) * dy)

    def shift(self, figure: Figure, dx: float, dy: float) -> None:
        """Move the box by data distances (a mouse drag)."""
        x0, x1, y0, y1 = self.box or data_box(figure)
        box = (x0 + dx, x1 + dx, y0 + dy, y1 + dy)
        if _showable(box, figure.log_x):
            self.box = box

    def move(self, figure: Figure, step: int, column: float | None = None) -> None:
        """Move the cursor along the probe (it appears at its start, else the middle point,
        first): ``step`` points, or, on a probe that runs left to right with ``column`` (the
        data width of one column of the view) given, to the first point ``step`` columns
        away (one point at least): the step follows the zoom, a column zoomed out, a point
        zoomed in."""
        probe = self.probe(figure)
        if probe is None or not probe.x:
            return
        n = len(probe.x)
        if self.cursor is None:
            self.cursor = n // 2 if probe.start is None else min(probe.start, n - 1)
            return
        x = np.asarray(probe.x, dtype=float)
        i = min(self.cursor, n - 1)
        if column and column > 0 and n > 1 and bool(np.all(np.diff(x) > 0)):
            target = x[i] + step * column
            j = (
                max(int(np.searchsorted(x, target)), i + 1)
                if step > 0
                else min(int(np.searchsorted(x, target, "right")) - 1, i - 1)
            )
        else:
            j = i + step
        self.cursor = min(max(j, 0), n - 1)

    def go_to(self, figure: Figure, value: float) -> bool:
        """Put the cursor on the probe's point nearest x = ``value`` (on a frequency axis,
        ``value`` is the frequency: x is its log10); False when there is no such point."""
        probe = self.probe(figure)
        if probe is None or not probe.x or not math.isfinite(value) or (figure.log_x and value <= 0):
            return False
        x = math.log10(value) if figure.log_x else value
        self.cursor = int(np.argmin(np.abs(np.asarray(probe.x, dtype=float) - x)))
        return True

    def pick(self, figure: Figure, x: float, y: float, scale: tuple[float, float]) -> None:
        """Put the cursor on the point nearest (x, y) of the nearest curve; ``scale``: the
        cells per data unit across and up, so nearness is what the eye sees.  The figure's
        probe (its rich readout) wins within a cell of any other curve: it runs along one."""
        found = [(_nearest(figure.probe.x, figure.probe.y, x, y, scale), figure.probe)] if figure.probe else []
        for s in figure.series:
            if s.x and s.label != "cursor":
                found.append((_nearest(s.x, s.y, x, y, scale), xy_probe(s, figure.xlabel or "x", figure.ylabel or "y")))
        if not found:
            return
        (distance, index), probe = min(found, key=lambda item: item[0][0])
        if figure.probe is not None and found[0][0][0] <= distance + 1.0:
            (distance, index), probe = found[0]
        if math.isfinite(distance):
            self.picked = None if probe is figure.probe else _labelled(probe, series_label(figure, probe))
            self.cursor = index

    def _point(self, figure: Figure) -> tuple[float, float] | None:
        probe = self.probe(figure)
        if self.cursor is None or probe is None or self.cursor >= len(probe.x):
            return None
        return probe.x[self.cursor], probe.y[self.cursor]

    def applied(self, figure: Figure) -> Figure:
        """The figure as shown: the box as its limits, the cursor marked and read out."""
        if self.box is None and self.cursor is None:
            return figure
        out = (
            figure
            if self.box is None
            else replace(
                figure, xlim=self.box[:2], ylim=self.box[2:], xticks=log_ticks(*self.box[:2]) if figure.log_x else None
            )
        )
        point = self._point(figure)
        if point is not None:
            out = replace(
                out,
                title=self.probe(figure).readout(self.cursor),
                series=out.series + [Series([point[0]], [point[1]], "cursor", marker="+", scatter=True, color="red")],
            )
        return out


def grab(figure: Figure, x: float, y: float, scale: tuple[float, float]) -> Handle | None:
    """What a press at (x, y) grabs: the nearest of the figure's handles within
    `GRAB_CELLS`, else (a figure whose curve drags: `Figure.curve_motion`) its curve, when
    a point of its probe is within them (the handle at the press's point: a drag moves by
    the pointer's travel); None: the press pans.  ``scale`` as `Navigation.pick`'s."""
    handles = figure.handles
    distance, index = _nearest([h.x for h in handles], [h.y for h in handles], x, y, scale)
    if distance <= GRAB_CELLS:
        return handles[index]
    probe = figure.probe
    if figure.curve_motion and probe is not None:
        if _nearest(probe.x, probe.y, x, y, scale)[0] <= GRAB_CELLS:
            return Handle(x, y, "", figure.curve_motion)
    return None


def nearest_index(probe: Probe, x: float, y: float, scale: tuple[float, float]) -> int:
    """The index of the probe's point nearest (x, y) (a drag along a locus branch)."""
    return _nearest(probe.x, probe.y, x, y, scale)[1]


def _showable(box: Box, log_x: bool) -> bool:
    """Whether a zoomed or panned box can be drawn: ordered, and within `LIMIT` (a log10
    axis within `LOG_LIMIT`: 1e-300 to 1e300), so that its ticks' arithmetic stays finite;
    a key that would leave it does nothing."""
    x0, x1, y0, y1 = box
    x_limit = LOG_LIMIT if log_x else LIMIT
    return x0 < x1 and y0 < y1 and -x_limit <= x0 and x1 <= x_limit and -LIMIT <= y0 and y1 <= LIMIT


def _nearest(xs, ys, x: float, y: float, scale: tuple[float, float]) -> tuple[float, int]:
    """(distance in cells, index) of the point of a curve nearest (x, y); (inf, 0) for no point."""
    d = np.hypot((np.asarray(xs, dtype=float) - x) * scale[0], (np.asarray(ys, dtype=float) - y) * scale[1])
    if d.size == 0:
        return math.inf, 0
    d[~np.isfinite(d)] = math.inf
    i = int(np.argmin(d))
    return float(d[i]), i


def series_label(figure: Figure, probe: Probe) -> str:
    """The label of the series a picked probe runs along."""
    return next((s.label for s in figure.series if s.x is probe.x and s.label), "")


def _labelled(probe: Probe, label: str) -> Probe:
    if not label:
        return probe
    return replace(probe, readout=lambda i: f"{label}: {probe.readout(i)}")


def data_box(figure: Figure) -> Box:
    """The figure's limits, else its data's extent (with a little room)."""
    xs = [v for s in figure.series for v in s.x if math.isfinite(v)]
    ys = [v for s in figure.series for v in s.y if math.isfinite(v)]
    x0, x1 = figure.xlim or ((min(xs), max(xs)) if xs else (0.0, 1.0))
    y0, y1 = figure.ylim or ((min(ys), max(ys)) if ys else (0.0, 1.0))
    if x1 <= x0:
        x0, x1 = x0 - 0.5, x0 + 0.5
    if y1 <= y0:
        y0, y1 = y0 - 0.5, y0 + 0.5
    return float(x0), float(x1), float(y0), float(y1)


def log_ticks(x0: float, x1: float) -> tuple[list[float], list[str]]:
    """Ticks of a log10 axis between x0 and x1 at 1, 2, 5 times powers of ten
    (thirds of the span, labelled as frequencies, when fewer than two fall inside)."""
    ticks = [math.log10(m * 10.0**k) for k in range(math.floor(x0) - 1, math.ceil(x1) + 1) for m in (1, 2, 5)]
    inside = [t for t in ticks if x0 <= t <= x1]
    if len(inside) > 6:
        inside = [t for t in inside if abs(t - round(t)) < 1e-9] or inside[::3]
    if len(inside) < 2:
        inside = [x0 + (x1 - x0) * f for f in (0.1, 0.5, 0.9)]
    return inside, [f"{10.0**t:.3g}" for t in inside]

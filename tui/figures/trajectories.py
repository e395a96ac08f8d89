"""The Trajectories plot of a projection session with an open loop (report 004's
reactor): two panels over one time axis, in the system's `time_unit`.

* the bounded inputs (the keys of the current record's `peaks`, e.g. u2):
  the current iterate, its bound lines (u_min/u_max of the system's data)
  and the untrimmed open loop (`records[0].extra["open_loop"]["u"]`, gray,
  "initial (untrimmed)").  The reactor's open loop peaks 14 times over the
  bound, so the axis stops at OFF_SCALE times the larger of the bound and the
  current peak, and the title gives the open loop's peak;
* the trim inputs (`open_loop["zero_inputs"]`, numbers from 1: u6, u7) on
  their own axis (some 200 times smaller than u2); the open loop holds them at 0.

The time ticks are under the lower panel only.  On a short canvas (80x24)
the figure's `compact` variant leaves out the legend entries that the title
and the ticks already give, and the time axis' label (the unit goes on the
last tick).  Only figures are built here; `plots` draws them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from tui.figures.axes import finite_points
from tui.figures.data import Figure, Series

COLORS = ("blue", "orange", "magenta", "cyan", "green")
INITIAL_COLOR = "gray"
BOUND_COLOR = "red"
OFF_SCALE = 2.0  # the bounded panel shows up to this times the bound (or the current peak)


def projection_figure(current: Mapping, initial: Mapping, system: Mapping) -> Figure:
    """The panels from the current record's extra, the open loop and the system's data (no
    panel when neither bounded nor trim inputs are named: the caller falls back)."""
    figure = _panels(current, initial, system, compact=False)
    figure.compact = _panels(current, initial, system, compact=True)
    return figure


def _panels(current: Mapping, initial: Mapping, system: Mapping, compact: bool) -> Figure:
    unit = time_unit(system)
    t = np.asarray(current["t"], dtype=float) / unit[1]
    u, u0 = np.asarray(current["u"], dtype=float), np.asarray(initial["u"], dtype=float)
    bounded = [input_index(key) for key in current.get("peaks", {})]
    trims = [input_index(key) for key in initial.get("zero_inputs", [])]
    panels = []
    if bounded:
        panels.append(bounded_panel(t, u, u0, bounded, system, initial.get("peaks", {}), unit, compact))
    if trims:
        panels.append(trim_panel(t, u, trims))
    if not panels:
        return Figure()
    width = max(len(label) for p in panels for label in p.yticks[1])
    for panel in panels:
        panel.xlim, panel.xticks = (float(t[0]), float(t[-1])), ([], [])
        panel.yticks = (panel.yticks[0], [label.rjust(width) for label in panel.yticks[1]])
    panels[-1].xticks = time_ticks(float(t[0]), float(t[-1]), unit[0] if compact else "")
    panels[-1].xlabel = "" if compact else f"t ({unit[0]})"
    return Figure(title=panels[0].title, panels=panels)


def bounded_panel(
    t: np.ndarray,
    u: np.ndarray,
    u0: np.ndarray,
    inputs: list[int],
    system: Mapping,
    peaks: Mapping,
    unit: tuple[str, float],
    compact: bool = False,
) -> Figure:
    """The bounded inputs now, their bound lines and the untrimmed open loop, the axis cut at
    OFF_SCALE times the larger of the bounds and the current peak when the open loop goes past."""
    names = [f"u{j + 1}" for j in inputs]
    fig = Figure(title=f"Bounded input{'s' if len(names) > 1 else ''} {', '.join(names)}")
    levels = [level for j in inputs for level in bounds(system, j, peaks.get(f"u{j + 1}"))]
    span = [float(t[0]), float(t[-1])]
    for k, level in enumerate(levels):  # first: the curves are drawn over them
        label = "" if k or compact else bound_label(levels)
        fig.series.append(Series(span, [level, level], label, marker="─", color=BOUND_COLOR))
    for k, j in enumerate(inputs):
        label = "initial (untrimmed)" if k == 0 else f"initial {names[k]}"
        fig.series.append(Series(*finite_points(t, u0[:, j]), label, color=INITIAL_COLOR))
    for k, j in enumerate(inputs):
        label = "" if compact else names[k]
        fig.series.append(Series(*finite_points(t, u[:, j]), label, color=COLORS[k % len(COLORS)]))
    shown = np.concatenate([u[:, inputs].ravel(), u0[:, inputs].ravel(), levels])
    limit = OFF_SCALE * max([abs(v) for v in levels] + [float(np.abs(u[:, inputs]).max(initial=0))])
    if float(np.abs(u0[:, inputs]).max(initial=0)) > limit > 0:
        peak = peaks.get(names[0], {})
        if "value" in peak:
            at = f"{short(peak['time'] / unit[1])} {unit[0]}"
            fig.title = f"{names[0]}: untrimmed peak {short(peak['value'])} at {at}"
        shown = np.clip(shown, -limit, limit)
    shown = shown[np.isfinite(shown)]
    fig.ylim, fig.yticks = axis(float(shown.min(initial=0)), float(shown.max(initial=0)), marks=levels)
    return fig


def trim_panel(t: np.ndarray, u: np.ndarray, inputs: list[int]) -> Figure:
    """The trim inputs of the current iterate on their own axis."""
    names = [f"u{j + 1}" for j in inputs]
    fig = Figure(title=f"Trim input{'s' if len(names) > 1 else ''} {', '.join(names)} (untrimmed: 0)")
    for k, j in enumerate(inputs):
        fig.series.append(Series(*finite_points(t, u[:, j]), names[k], color=COLORS[k % len(COLORS)]))
    values = u[:, inputs][np.isfinite(u[:, inputs])]
    fig.ylim, fig.yticks = axis(float(values.min(initial=0)), float(values.max(initial=0)))
    return fig


def input_index(key: int | str) -> int:
    """0-based index of an input given by its number from 1 (6) or its name ('u6')."""
    return int(str(key).removeprefix("u")) - 1


def time_unit(system: Mapping) -> tuple[str, float]:
    """(name, seconds per unit) of the system's `time_unit` (["h", 3600]); seconds when absent."""
    try:
        name, seconds = str(system["time_unit"][0]), float(system["time_unit"][1])
    except (KeyError, TypeError, ValueError, IndexError):
        return "s", 1.0
    return (name, seconds) if seconds > 0 else ("s", 1.0)


def bounds(system: Mapping, j: int, peak: Mapping | None) -> list[float]:
    """Input j's finite u_min and u_max from the system's data, else the peak's +-bound."""
    levels = []
    for key in ("u_min", "u_max"):
        values = system.get(key) or []
        if j < len(values) and values[j] is not None and math.isfinite(float(values[j])):
            levels.append(float(values[j]))
    if not levels and peak and "bound" in peak:
        levels = [-float(peak["bound"]), float(peak["bound"])]
    return levels


def bound_label(levels: list[float]) -> str:
    """'bound ±4e13' for a symmetric pair, else the levels."""
    if len(levels) == 2 and levels[0] == -levels[1]:
        return f"bound ±{short(abs(levels[0]))}"
    return "bound " + ", ".join(short(v) for v in levels)


def _step(span: float, count: int) -> float:
    """A round step (1, 2, 2.5 or 5 times a power of 10) giving about `count` ticks over `span`."""
    raw = span / count
    if not math.isfinite(raw) or raw <= 0:  # a degenerate or overflowing span: one step over it
        return 1.0
    power = 10.0 ** math.floor(math.log10(raw))
    return next((m * power for m in (1, 2, 2.5, 5, 10) if m * power >= raw), 10 * power)


def axis(
    lo: float, hi: float, count: int = 4, marks: list[float] = ()
) -> tuple[tuple[float, float], tuple[list[float], list[str]]]:
    """Limits a little wider than [lo, hi], and round ticks (about `count`) labelled shortly;
    `marks` (the bounds) are ticks too, the round ticks nearer than half a step to one dropped."""
    if not hi > lo:
        lo, hi = lo - max(abs(lo), 1.0), hi + max(abs(hi), 1.0)
    pad = 0.05 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    step = _step(hi - lo, count)
    ticks = [k * step for k in range(math.ceil(lo / step), math.floor(hi / step) + 1)]
    ticks = sorted([v for v in ticks if all(abs(v - m) >= step / 2 for m in marks)] + list(marks))
    return (lo, hi), (ticks, [short(v) for v in ticks])


def time_ticks(t0: float, t1: float, unit: str = "", count: int = 4) -> tuple[list[float], list[str]]:
    """Round time ticks over [t0, t1]; with `unit`, the last label carries it ("40 h")."""
    if not t1 > t0:
        return [t0], [short(t0) + (f" {unit}" if unit else "")]
    step = _step(t1 - t0, count)
    ticks = [k * step for k in range(math.ceil(t0 / step - 1e-9), math.floor(t1 / step + 1e-9) + 1)]
    labels = [short(v) for v in ticks]
    if unit:
        labels[-1] += f" {unit}"
    return ticks, labels


def short(value: float) -> str:
    """3 significant digits, the exponent without '+' or leading zeros: 4e13, -5.46e14, 0.25."""
    text = f"{value:.3g}"
    if "e" not in text:
        return text
    mantissa, exponent = text.split("e")
    return f"{mantissa}e{int(exponent)}"


def trajectories_figure(data: Mapping | None, system: Mapping | None = None) -> Figure:
    """Controls u_j(t) of the current iterate, from a presenter's trajectories
    ({"t", "x", "u", "current"} and maybe "open_loop"); with the untrimmed open
    loop (report 004's reactor), `projection_figure`'s two panels instead."""
    if data is not None and data.get("open_loop") is not None:
        figure = projection_figure(data["current"], data["open_loop"], system or {})
        if figure.panels:
            return figure
    fig = Figure(xlabel="t", ylabel="u", empty_message="no trajectories (projection sessions have them)")
    if data is None:
        return fig
    fig.title = "Controls u(t)"
    columns = np.array(data["u"], dtype=float)
    for j in range(columns.shape[1]):
        fig.series.append(Series(list(map(float, data["t"])), columns[:, j].tolist(), f"u{j + 1}"))
    return fig

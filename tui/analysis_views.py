"""The views of the closed loop a classical designer reads beside Bode and
Nyquist: |S|, |T| and |KS| with their refined peaks, the pole-zero map of
the open and the closed loop, and the root locus in the loop gain.  Figures
for `tui.widgets.plots` from the engine's `sensitivity` and `root_locus`
(rational loops; a tabulated loop shows |S| and |T| on its own grid)."""

from __future__ import annotations

import math

import numpy as np

from engine.errors import EngineError
from engine.loops import loop_model
from engine.sensitivity import (compensator_peak, complementary_peak, magnitude_curves, sensitivity_peak,
                                transfer_evaluator)

from .views import CONDITION_COLORS
from .widgets.plots import Figure, Series, _decades, _finite

LOCUS_POINTS = 2000   # the engine's default bound


def sensitivity_figure(view) -> Figure:
    """|S|, |T| (and |KS| where a block is named compensator) in dB against log
    frequency for each plotted condition at the current design, Ms and Mt marked."""
    problem = view.problem
    unit = problem.grid.unit
    scale = 2 * np.pi if unit == "hz" else 1.0
    fig = Figure(title="Closed loop: |S|, |T|", xlabel=f"frequency ({unit})", ylabel="dB",
                 empty_message="no closed loop to show", log_x=True)
    notes = []
    for k in view.plotted():
        c = problem.conditions[k]
        params = view.parameters(None, k)
        try:
            loop = loop_model(c.network, c.break_at, problem.grid.omega, params)
            w, s, t = magnitude_curves(loop)
            ms, mt = sensitivity_peak(loop), complementary_peak(loop)
        except EngineError as exc:
            notes.append(f"{c.name}: {exc}")
            continue
        several = len(view.plotted()) > 1   # then each condition in its colour, T dotted
        prefix = f"{c.name} " if len(problem.conditions) > 1 else ""
        s_color, t_color = (CONDITION_COLORS[k % len(CONDITION_COLORS)],) * 2 if several else ("blue", "orange")
        lw = np.log10(w / scale)
        with np.errstate(divide="ignore"):
            fig.series.append(Series(*_finite(lw, 20 * np.log10(s)), f"{prefix}|S|", color=s_color))
            fig.series.append(Series(*_finite(lw, 20 * np.log10(t)), f"{prefix}|T|", color=t_color,
                                     marker="dot" if several else "braille"))
        if not several:
            _compensator_curve(fig, c, params, loop, lw, scale, prefix)
        for name, peak, color in (("Ms", ms, s_color), ("Mt", mt, t_color)):
            if 0 < peak.frequency < math.inf and peak.value > 0:
                fig.series.append(Series([math.log10(peak.frequency / scale)], [peak.db],
                                         f"{prefix}{name} {peak.value:.4g} ({peak.db:.2f} dB)", marker="x",
                                         scatter=True, color=color))
        fig.xticks = _decades(lw, unit)
    if notes and not fig.series:
        fig.empty_message = "; ".join(notes)
    return fig


def _compensator_curve(fig: Figure, condition, params, loop, lw, scale: float, prefix: str) -> None:
    """|K S|, K the one block that reads the break signal (the compensator of a
    unity loop broken at its error): the control effort, with its refined peak."""
    network = condition.network
    reading = [e for e in network.entries if e.col == network.signal(condition.break_at)]
    if len(reading) != 1 or not network.rational:
        return
    evaluate = transfer_evaluator(reading[0].transfer, params)
    name = network.signals[reading[0].row]
    with np.errstate(all="ignore"):
        ks = np.abs(evaluate(loop.omega)[0] / (1.0 + loop.gh))
        fig.series.append(Series(*_finite(lw, 20 * np.log10(ks)), f"{prefix}|KS| ({condition.break_at}->{name})",
                                 color="magenta"))
    try:
        peak = compensator_peak(loop, evaluate)
    except EngineError:
        return
    if 0 < peak.frequency < math.inf:
        fig.series.append(Series([math.log10(peak.frequency / scale)], [peak.db], f"{prefix}max|KS| {peak.db:.2f} dB",
                                 marker="x", scatter=True, color="magenta"))


def poles_figure(view) -> Figure:
    """Open-loop poles (x) and zeros (o) and the closed-loop poles (*) of the first plotted condition."""
    fig = Figure(title="Poles and zeros", xlabel="Re", ylabel="Im", empty_message="no pole-zero map (needs a rational loop)")
    k = view.plotted()[0] if view.plotted() else 0
    c = _rational(view, k)
    if c is None:
        return fig
    from engine.root_locus import pole_zero_map   # scipy.optimize, on first use
    try:
        pz = pole_zero_map(c.network, c.break_at, view.parameters(None, k))
    except EngineError as exc:
        fig.empty_message = f"no pole-zero map: {exc}"
        return fig
    for points, label, marker, color in ((pz.poles, "open-loop poles", "x", "blue"),
                                         (pz.zeros, "open-loop zeros", "o", "blue"),
                                         (pz.closed_loop, "closed-loop poles", "*", "red")):
        points = np.asarray(points)[np.isfinite(points)]
        if points.size:
            fig.series.append(Series(points.real.tolist(), points.imag.tolist(), label, marker=marker,
                                     scatter=True, color=color))
    fig.title = f"Poles and zeros: {c.name}"
    if len(pz.closed_loop):
        fig.xlabel = f"Re   slowest closed-loop pole {_pole_text(pz.closed_loop)}"
    _square(fig, np.concatenate([pz.poles, pz.zeros, pz.closed_loop]))
    return fig


PARAMETER_LOCUS_POINTS = 300   # each point is a realization and its polish (~10 ms)


def locus_figure(view, parameter: str = "gain") -> Figure:
    """The root locus of the first plotted condition in the loop gain k (or in a named
    parameter, a decade either side of its value), the current closed-loop poles
    marked, the imaginary-axis crossings below."""
    fig = Figure(title="Root locus (loop gain k)", xlabel="Re", ylabel="Im",
                 empty_message="no root locus (needs a rational loop)")
    k = view.plotted()[0] if view.plotted() else 0
    c = _rational(view, k)
    if c is None:
        return fig
    from engine.root_locus import root_locus
    try:
        points = LOCUS_POINTS if parameter == "gain" else PARAMETER_LOCUS_POINTS
        locus = root_locus(c.network, c.break_at, view.parameters(None, k), parameter, max_points=points,
                           polished=False)
    except EngineError as exc:
        fig.empty_message = f"no root locus: {exc}"
        return fig
    branches = np.asarray(locus.branches)
    for j in range(branches.shape[1]):
        column = branches[:, j]
        keep = np.isfinite(column)
        fig.series.append(Series(column.real[keep].tolist(), column.imag[keep].tolist(),
                                 "branches" if j == 0 else "", color="blue"))
    current = np.asarray(locus.current)
    now = "k = 1" if parameter == "gain" else f"{parameter} = {locus.current_value:.5g}"
    fig.series.append(Series(current.real.tolist(), current.imag.tolist(), f"{now} (current)", marker="*",
                             scatter=True, color="red"))
    name = "k" if parameter == "gain" else parameter
    crossings = ", ".join(f"{name}={x.value:.4g} at {x.frequency:.4g} rad/s" for x in locus.crossings[:3])
    fig.title = f"Root locus in {'the loop gain' if parameter == 'gain' else parameter}: {c.name}" + ("" if locus.status == "complete" else f" ({locus.status})")
    if crossings:
        fig.xlabel = f"Re   jw-axis crossings: {crossings}"
    _square(fig, np.concatenate([current, branches[np.isfinite(branches)]]), current)
    return fig


def _rational(view, k: int):
    problem = view.problem
    if k >= len(problem.conditions) or not problem.conditions[k].network.rational:
        return None
    return problem.conditions[k]


def _pole_text(poles) -> str:
    p = min(np.asarray(poles), key=lambda z: abs(z.real))
    wn = abs(p)
    zeta = -p.real / wn if wn > 0 else 1.0
    return f"{p.real:.4g}{p.imag:+.4g}j, zeta {zeta:.3g}, wn {wn:.4g}"


def _square(fig: Figure, points: np.ndarray, focus: np.ndarray | None = None) -> None:
    """Axis limits about the points of interest (the current poles when given), with a margin."""
    points = np.asarray(points)
    points = points[np.isfinite(points)]
    if not points.size:
        return
    around = points if focus is None or not np.asarray(focus).size else np.asarray(focus)
    span = max(np.ptp(around.real), np.ptp(around.imag), 1e-3 * max(1.0, np.abs(around).max()))
    re_mid, im_mid = (around.real.max() + around.real.min()) / 2, 0.0
    half = 0.75 * max(span, 2 * np.abs(around.imag).max()) + 1e-12
    fig.xlim = (re_mid - 1.3 * half, re_mid + 1.3 * half)
    fig.ylim = (im_mid - half, im_mid + half)


MAX_POLES_LISTED = 8


def pole_lines(view) -> str:
    """The current design's closed-loop poles of the first plotted condition (a conjugate pair
    once, as re +- im j) with zeta and wn, the least damped first; '' for a tabulated loop."""
    from engine.polish import polish
    from engine.realization import poles
    k = view.plotted()[0] if view.plotted() else 0
    c = _rational(view, k)
    ss = view.step_loop(k) if c is not None else None
    if ss is None:
        return ""
    params = view.parameters(None, k)
    try:
        found = poles(ss, lambda eig: polish(c.network, params, eig))
    except EngineError:
        found = poles(ss)
    shown = sorted((p for p in found if p.value.imag >= 0), key=lambda p: (p.zeta, p.wn))
    lines = [f"closed-loop poles ({c.name})" if len(view.problem.conditions) > 1 else "closed-loop poles",
             f"{'pole':>22} {'zeta':>7} {'wn rad/s' if c.network.variable == 's' else 'wn (w)':>10}"]
    for p in shown[:MAX_POLES_LISTED]:
        value = f"{p.value.real:.5g}" + (f" +- {p.value.imag:.5g}j" if p.value.imag > 0 else "")
        lines.append(f"{value:>22} {p.zeta:>7.3g} {p.wn:>10.5g}")
    if len(shown) > MAX_POLES_LISTED:
        lines.append(f"... {len(shown) - MAX_POLES_LISTED} more (the Poles plot shows them all)")
    return "\n".join(lines)

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
        prefix = f"{c.name} " if len(problem.conditions) > 1 else ""
        lw = np.log10(w / scale)
        with np.errstate(divide="ignore"):
            fig.series.append(Series(*_finite(lw, 20 * np.log10(s)), f"{prefix}|S|", color="blue"))
            fig.series.append(Series(*_finite(lw, 20 * np.log10(t)), f"{prefix}|T|", color="orange"))
        _compensator_curve(fig, c, params, loop, lw, scale, prefix)
        for name, peak, color in (("Ms", ms, "blue"), ("Mt", mt, "orange")):
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


def locus_figure(view) -> Figure:
    """The root locus in the loop gain of the first plotted condition, the current
    closed-loop poles marked, the imaginary-axis crossings listed in the title."""
    fig = Figure(title="Root locus (loop gain k)", xlabel="Re", ylabel="Im",
                 empty_message="no root locus (needs a rational loop)")
    k = view.plotted()[0] if view.plotted() else 0
    c = _rational(view, k)
    if c is None:
        return fig
    from engine.root_locus import root_locus
    try:
        locus = root_locus(c.network, c.break_at, view.parameters(None, k), max_points=LOCUS_POINTS, polished=False)
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
    fig.series.append(Series(current.real.tolist(), current.imag.tolist(), "k = 1 (current)", marker="*",
                             scatter=True, color="red"))
    crossings = ", ".join(f"k={x.value:.4g} at {x.frequency:.4g} rad/s" for x in locus.crossings[:3])
    fig.title = f"Root locus: {c.name}" + ("" if locus.status == "complete" else f" ({locus.status})")
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

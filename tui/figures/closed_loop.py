"""The views of the closed loop a classical designer reads beside Bode and
Nyquist: |S|, |T| and |KS| with their refined peaks, the pole-zero map of
the open and the closed loop, and the root locus in the loop gain.  Figures
for `tui.widgets.plots` from the engine's `sensitivity` and `root_locus`
(rational loops; a tabulated loop shows |S| and |T| on its own grid).

Each draws some designs, as `View.shown` lists them: (iteration or None for
the current one, condition, label, colour); by default the current design of
each plotted condition.  A gray design is a reference drawn beside the others
(the History tab's marked iteration, or the current design)."""

from __future__ import annotations

import math

import numpy as np

from engine.closed_loop.poles import closed_loop_verdict
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.margins.peaks import (
    compensator_peak,
    complementary_peak,
    magnitude_curves,
    sensitivity_peak,
    transfer_evaluator,
)
from engine.model.bilinear import damping, z_of_s
from tui.figures.axes import decade_ticks, finite_points
from tui.figures.data import REFERENCE_COLOR, REFERENCE_MARKER, Figure, Series, role_color, role_style
from tui.figures.navigation import Probe

LOCUS_POINTS = 2000  # the engine's default bound

Design = tuple[int | None, int, str, str]  # (iteration or None: the current one, condition, label, role)


def current_designs(view) -> list[Design]:
    """The current design of each plotted condition (named when the session has several)."""
    plotted, conditions = view.plotted(), view.problem.conditions
    named = len(conditions) > 1
    return [
        (
            None,
            k,
            conditions[k].name if named else "",
            "condition" if len(plotted) > 1 else "current",
        )
        for k in plotted
    ]


UNBOUNDED = "unstable: Ms, Mt, max|KS| unbounded"


def sensitivity_figure(view, designs: list[Design] | None = None) -> Figure:
    """|S|, |T| in dB against log frequency for each design (the current design of each
    plotted condition by default), Ms and Mt marked; |KS| too where one design is drawn
    in blue.  Beside a gray reference, the blue design's peaks are in the title and the
    reference has one legend entry.  The cursor reads |S| and |T| of the first design."""
    designs = current_designs(view) if designs is None else designs
    unit = view.problem.grid.unit
    fig = Figure(
        title="Closed loop: |S|, |T|",
        xlabel=f"frequency ({unit})",
        ylabel="dB",
        empty_message="no closed loop to show",
        log_x=True,
    )
    notes: list[str] = []
    references = any(d[3] == "reference" for d in designs)
    paired = sum(d[3] != "reference" for d in designs) == 1
    for design in designs:
        role = "reference" if design[3] == "reference" else "paired" if paired else "condition"
        _closed_loop(fig, view, design, role, references, notes)
    if notes and not fig.series:
        fig.empty_message = "; ".join(notes)
    return fig


def _closed_loop(fig: Figure, view, design: Design, role: str, condensed: bool, notes: list[str]) -> None:
    """One design's |S| and |T| and their refined peaks: ``role`` paired: |S| blue, |T|
    orange, with |KS|; condition: both in its colour, |T| dotted; reference: gray, one
    legend entry.  ``condensed``: the paired design's peaks in the title, not the legend."""
    at, k, label, drawn_as = design
    color = role_color(drawn_as, k)
    problem = view.problem
    c = problem.conditions[k]
    scale = 2 * np.pi if problem.grid.unit == "hz" else 1.0
    params = view.parameters(at, k)
    try:
        loop = loop_model(c.network, c.break_at, problem.grid.omega, params)
        w, s, t = magnitude_curves(loop)
        ms, mt = sensitivity_peak(loop), complementary_peak(loop)
    except EngineError as exc:
        notes.append(f"{label or c.name}: {exc}")
        return
    prefix = f"{label} " if label and not (role == "paired" and condensed) else ""
    s_color, t_color = ("blue", "orange") if role == "paired" else (color, color)
    lw = np.log10(w / scale)
    with np.errstate(divide="ignore"):
        s_db, t_db = 20 * np.log10(s), 20 * np.log10(t)
    unstable = closed_loop_verdict(c.network, params) == "unstable"
    peaks = UNBOUNDED if unstable else f"Ms {ms.value:.4g}, Mt {mt.value:.4g}"
    if unstable and role != "reference":
        fig.title += f"  ({UNBOUNDED})"
    s_marker = "braille" if role == "paired" else role_style(drawn_as, k)["marker"]
    t_marker = REFERENCE_MARKER if role == "reference" else "dot"  # |T| dotted beside |S|: told apart without colour
    s_label = f"{label}: {peaks}" if role == "reference" else f"{prefix}|S|"
    beneath = role == "reference"
    fig.series.append(Series(*finite_points(lw, s_db), s_label, color=s_color, marker=s_marker, beneath=beneath))
    t_label = "" if role == "reference" else f"{prefix}|T|"
    fig.series.append(Series(*finite_points(lw, t_db), t_label, color=t_color, marker=t_marker, beneath=beneath))
    if fig.probe is None:
        fig.probe = _magnitude_probe(lw, s_db, t_db, problem.grid.unit)
    effort = (
        _compensator_curve(fig, c, params, loop, lw, scale, prefix, condensed, unstable) if role == "paired" else ""
    )
    labelled = role == "condition" or (role == "paired" and not condensed)
    for name, peak, peak_color in (("Ms", ms, s_color), ("Mt", mt, t_color)):
        if 0 < peak.frequency < math.inf and 0 < peak.value < math.inf:
            value = f"unbounded (on the axis {peak.value:.4g})" if unstable else f"{peak.value:.4g} ({peak.db:.2f} dB)"
            fig.series.append(
                Series(
                    [math.log10(peak.frequency / scale)],
                    [peak.db],
                    f"{prefix}{name} {value}" if labelled else "",
                    marker="x",
                    scatter=True,
                    color=peak_color,
                )
            )
            if role == "paired" and condensed and not unstable:
                fig.title += f"  {name} {peak.value:.4g}"
    fig.title += f"  {effort}" if effort else ""
    fig.xticks = decade_ticks(lw)


def _magnitude_probe(lw: np.ndarray, s_db: np.ndarray, t_db: np.ndarray, unit: str) -> Probe:
    """A cursor along |S|: the frequency, |S| and |T| there."""
    keep = np.isfinite(lw) & np.isfinite(s_db)
    lw, s_db, t_db = lw[keep], s_db[keep], t_db[keep]

    def readout(i: int) -> str:
        return f"w = {10.0 ** lw[i]:.6g} {unit}  |S| = {s_db[i]:.4f} dB  |T| = {t_db[i]:.4f} dB"

    return Probe(lw.tolist(), s_db.tolist(), readout)


def _compensator_curve(
    fig: Figure, condition, params, loop, lw, scale: float, prefix: str, condensed: bool = False, unstable: bool = False
) -> str:
    """|K S|, K the one block that reads the break signal (the compensator of a
    unity loop broken at its error): the control effort, with its refined peak (unbounded
    when the closed loop is ``unstable``: its peak on the axis bounds nothing);
    ``condensed``: the peak's text is returned for the title, not put in the legend."""
    network = condition.network
    reading = [e for e in network.entries if e.col == network.signal(condition.break_at)]
    if len(reading) != 1 or not network.rational:
        return ""
    evaluate = transfer_evaluator(reading[0].transfer, params)
    name = network.signals[reading[0].row]
    with np.errstate(all="ignore"):
        ks = np.abs(evaluate(loop.omega)[0] / (1.0 + loop.gh))
        fig.series.append(
            Series(
                *finite_points(lw, 20 * np.log10(ks)),
                f"{prefix}|KS| ({condition.break_at}->{name})",
                color="magenta",
                marker="~",  # told from |S| (braille) and |T| (dots) without colour
            )
        )
    try:
        peak = compensator_peak(loop, evaluate)
    except EngineError:
        return ""
    if not 0 < peak.frequency < math.inf:
        return ""
    text = f"max|KS| unbounded (on the axis {peak.db:.2f} dB)" if unstable else f"max|KS| {peak.db:.2f} dB"
    fig.series.append(
        Series(
            [math.log10(peak.frequency / scale)],
            [peak.db],
            "" if condensed else prefix + text,
            marker="x",
            scatter=True,
            color="magenta",
        )
    )
    return text if condensed else ""


def poles_figure(view, designs: list[Design] | None = None) -> Figure:
    """Open-loop poles (x) and zeros (o) and the closed-loop poles (*) of the first design
    (the current one of the first plotted condition by default), and of the others on its
    condition in gray; the cursor steps through its closed-loop poles with zeta and wn."""
    fig = Figure(
        title="Poles and zeros", xlabel="Re", ylabel="Im", empty_message="no pole-zero map (needs a rational loop)"
    )
    designs = current_designs(view) if designs is None else designs
    designs = [d for d in designs if d[1] == designs[0][1]] if designs else []  # on the first one's condition
    c = _rational(view, designs[0][1]) if designs else None
    if c is None:
        return fig
    from engine.closed_loop.root_locus import pole_zero_map  # scipy.optimize, on first use

    T = c.network.sample_time
    shown = []
    for n, (at, k, label, _) in enumerate(designs):
        try:
            pz = pole_zero_map(c.network, c.break_at, view.parameters(at, k))
        except EngineError as exc:
            fig.empty_message = f"no pole-zero map: {exc}"
            return fig
        _pole_series(fig, pz, "" if n == 0 else label)
        shown.append(pz)
    first = shown[0]
    fig.title = f"Poles and zeros: {c.name}" + ("" if T is None else f" (in z, T = {T:g} s)")
    if len(first.closed_loop):
        fig.xlabel = f"Re   slowest closed-loop pole {_pole_text(first.closed_loop, T)}"
        fig.probe = _pole_probe(first.closed_loop, c.network.variable, T)
    _square(fig, np.concatenate([np.concatenate([pz.poles, pz.zeros, pz.closed_loop]) for pz in shown]))
    if T is not None:
        _z_grid(fig)
    return fig


Z_GRID_DAMPINGS = (0.3, 0.7)  # constant-damping curves drawn in z (as MATLAB's zgrid)
Z_GRID_FREQUENCIES = (0.25, 0.5, 0.75)  # constant natural frequencies, in units of pi/T


def _z_grid(fig: Figure) -> None:
    """The unit circle (the stability boundary in z) and, as MATLAB's zgrid, the curves of
    constant damping and of constant natural frequency of the s-plane equivalents (z = exp(s T)),
    beneath the roots, in a view that holds the circle."""
    angle = np.linspace(0.0, 2 * np.pi, 181)
    grid = [Series(np.cos(angle).tolist(), np.sin(angle).tolist(), "|z| = 1", color="gray", marker="dot", beneath=True)]
    for n, zeta in enumerate(Z_GRID_DAMPINGS):  # s T = x (-zeta + j sqrt(1 - zeta^2)), x from 0 to pi/sqrt(1 - zeta^2)
        x = np.linspace(0.0, np.pi / math.sqrt(1 - zeta**2), 90)
        upper = z_of_s(x * complex(-zeta, math.sqrt(1 - zeta**2)), 1.0)
        path = np.concatenate([upper, upper[::-1].conjugate()])
        label = f"zeta {', '.join(f'{z:g}' for z in Z_GRID_DAMPINGS)}; wn pi/T x {', '.join(f'{f:g}' for f in Z_GRID_FREQUENCIES)}"
        grid.append(
            Series(
                path.real.tolist(), path.imag.tolist(), label if n == 0 else "", color="gray", marker="·", beneath=True
            )
        )
    for fraction in Z_GRID_FREQUENCIES:  # wn T = fraction pi, zeta from 0 to 1
        zeta = np.linspace(0.0, 1.0, 45)
        upper = z_of_s(fraction * np.pi * (-zeta + 1j * np.sqrt(1 - zeta**2)), 1.0)
        path = np.concatenate([upper, upper[::-1].conjugate()])
        grid.append(Series(path.real.tolist(), path.imag.tolist(), "", color="gray", marker="·", beneath=True))
    fig.series[:0] = grid
    if fig.xlim and fig.ylim:
        fig.xlim = (min(fig.xlim[0], -1.2), max(fig.xlim[1], 1.2))
        fig.ylim = (min(fig.ylim[0], -1.2), max(fig.ylim[1], 1.2))


def _pole_series(fig: Figure, pz, reference: str) -> None:
    """A pole-zero map's points: blue and red, or all gray (one legend entry each for the
    open and the closed loop) when it is the ``reference`` design's."""
    rows = (
        (pz.poles, "open-loop poles", "x", "blue"),
        (pz.zeros, "open-loop zeros", "o", "blue"),
        (pz.closed_loop, "closed-loop poles", "*", "red"),
    )
    if reference:
        rows = (
            (pz.poles, f"{reference} open loop", "x", REFERENCE_COLOR),
            (pz.zeros, "", "o", REFERENCE_COLOR),
            (pz.closed_loop, f"{reference} closed loop", "*", REFERENCE_COLOR),
        )
    for points, label, marker, color in rows:
        points = np.asarray(points)[np.isfinite(points)]
        if points.size:
            fig.series.append(
                Series(points.real.tolist(), points.imag.tolist(), label, marker=marker, scatter=True, color=color)
            )


def _pole_probe(poles, variable: str, sample_time: float | None = None) -> Probe:
    """A cursor over the closed-loop poles (one of each conjugate pair), the least damped
    first, reading each one's zeta and wn (in z: of its s-plane equivalent)."""
    found = sorted(
        (p for p in np.asarray(poles) if np.isfinite(p) and p.imag >= 0), key=lambda p: damping(p, sample_time)
    )
    unit = " rad/s" if variable == "s" or sample_time is not None else ""

    def readout(i: int) -> str:
        p = found[i]
        zeta, wn = damping(p, sample_time)
        return f"pole {p.real:.5g}{p.imag:+.5g}j  zeta {zeta:.4g}  wn {wn:.5g}{unit}"

    return Probe([float(p.real) for p in found], [float(p.imag) for p in found], readout, start=0)


def _locus_probe(locus, name: str, sample_time: float | None = None) -> Probe:
    """A cursor along every branch (one after another), reading the gain (or parameter)
    there and the closed-loop poles it gives; enter picks that value (`Probe.chosen`)."""
    branches = np.asarray(locus.branches)
    rows, count = branches.shape
    points = branches.T.ravel()  # branch by branch
    keep = np.flatnonzero(np.isfinite(points))
    values = np.tile(locus.values, count)[keep]
    rows_of = np.tile(np.arange(rows), count)[keep]

    def readout(i: int) -> str:
        poles = [p for p in branches[rows_of[i]] if np.isfinite(p) and p.imag >= 0]
        least = min(poles, key=lambda p: damping(p, sample_time)[0], default=None)
        zeta, wn = (None, None) if least is None else damping(least, sample_time)
        damped = "" if least is None else f"  least damped zeta {zeta:.3g} wn {wn:.4g}"
        return f"{name} = {values[i]:.5g}: poles " + ", ".join(_root_text(p) for p in poles[:4]) + damped

    start = int(np.argmin(np.abs(values - locus.current_value))) if values.size else None
    return Probe(points.real[keep].tolist(), points.imag[keep].tolist(), readout, start, lambda i: float(values[i]))


def _root_text(p: complex) -> str:
    """A closed-loop pole, a pair written once: '-0.5+-1.2j', '-8.1'."""
    return f"{p.real:.4g}" if p.imag == 0 else f"{p.real:.4g}+-{p.imag:.4g}j"


PARAMETER_LOCUS_POINTS = 300  # each point is a realization and its polish (~10 ms)
COARSE_LOCUS_POINTS = 60  # the first, coarse locus the workbench draws while the fine one is computed


def locus_figure(
    view,
    parameter: str = "gain",
    iteration: int | None = None,
    subject: str | None = None,
    points: int | None = None,
    refining: bool = True,
) -> Figure:
    """The root locus of the first plotted condition at an iteration's design (None: the
    current one) in the loop gain k (or in a named parameter, a decade either side of its
    value), that design's closed-loop poles marked, the imaginary-axis crossings below;
    the title names ``subject`` (default: the condition).  ``points``: a coarse locus
    of at most so many points (its title says so), drawn while the fine one is computed
    (``refining``), else while a drag goes (the fine one on release)."""
    fig = Figure(
        title="Root locus (loop gain k)",
        xlabel="Re",
        ylabel="Im",
        empty_message="no root locus (needs a rational loop)",
    )
    k = view.first_plotted
    c = _rational(view, k)
    if c is None:
        return fig
    from engine.closed_loop.root_locus import root_locus

    try:
        bound = LOCUS_POINTS if parameter == "gain" else PARAMETER_LOCUS_POINTS
        locus = root_locus(
            c.network, c.break_at, view.parameters(iteration, k), parameter, max_points=points or bound, polished=False
        )
    except EngineError as exc:
        fig.empty_message = f"no root locus: {exc}"
        return fig
    T = c.network.sample_time
    branches = np.asarray(locus.branches)
    for j in range(branches.shape[1]):
        column = branches[:, j]
        keep = np.isfinite(column)
        fig.series.append(
            Series(column.real[keep].tolist(), column.imag[keep].tolist(), "branches" if j == 0 else "", color="blue")
        )
    current = np.asarray(locus.current)
    now = "k = 1" if parameter == "gain" else f"{parameter} = {locus.current_value:.5g}"
    design = "current" if iteration is None else f"iteration {iteration}" if iteration else "start"
    fig.series.append(
        Series(current.real.tolist(), current.imag.tolist(), f"{now} ({design})", marker="*", scatter=True, color="red")
    )
    name = "k" if parameter == "gain" else parameter
    crossings = ", ".join(f"{name}={x.value:.4g} at {x.frequency:.4g} rad/s" for x in locus.crossings[:3])
    coarse = "coarse: refining ..." if refining else "coarse: exact on release"
    status = coarse if points else "" if locus.status == "complete" else locus.status
    fig.title = f"Root locus in {'the loop gain' if parameter == 'gain' else parameter}: {subject or c.name}" + (
        f" ({status})" if status else ""
    )
    if crossings:
        fig.xlabel = f"Re   {'jw-axis' if T is None else 'unit-circle'} crossings: {crossings}"
    fig.probe = _locus_probe(locus, name, T)
    fig.curve_motion = "locus"  # dragged along a branch: the gain (or parameter) at the nearest point
    _square(fig, np.concatenate([current, branches[np.isfinite(branches)]]), current)
    if T is not None:
        _z_grid(fig)
    elif parameter == "gain":  # (in z, the w-plane's asymptotes are arcs: not drawn)
        _asymptotes_and_breakaways(fig, locus)
    return fig


def _asymptotes_and_breakaways(fig: Figure, locus) -> None:
    """A gain locus's asymptotes (gray, from the centroid to beyond the view) and
    breakaway points (+, with the gain there)."""
    if locus.centroid is not None and fig.xlim and fig.ylim:
        reach = 4 * max(abs(fig.xlim[0] - locus.centroid), abs(fig.xlim[1] - locus.centroid), abs(fig.ylim[1]))
        for n, angle in enumerate(locus.angles_deg):
            end = locus.centroid + reach * np.exp(1j * np.radians(angle))
            fig.series.append(
                Series(
                    [locus.centroid, end.real],
                    [0.0, end.imag],
                    f"asymptotes from {locus.centroid:.4g}" if n == 0 else "",
                    color="gray",
                    marker="dot",
                )
            )
    for n, (point, gain) in enumerate(locus.breakaways[:4]):
        fig.series.append(
            Series(
                [point.real],
                [point.imag],
                f"breakaway k={gain:.4g}" if n == 0 else "",
                marker="+",
                scatter=True,
                color="magenta",
            )
        )


def _rational(view, k: int):
    problem = view.problem
    if k >= len(problem.conditions) or not problem.conditions[k].network.rational:
        return None
    return problem.conditions[k]


def _pole_text(poles, sample_time: float | None = None) -> str:
    """The slowest pole (nearest the imaginary axis; in z, the unit circle) with its zeta and wn."""
    points = np.asarray(poles)
    p = min(points, key=lambda z: abs(z.real) if sample_time is None else abs(1 - abs(z)))
    zeta, wn = damping(p, sample_time)
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


def pole_text(view) -> str:
    """`pole_lines` when the view's presenter shows poles, never raising ('' then)."""
    if "poles" not in view.presenter.plots:
        return ""
    from engine.stepping.presenter import tolerant

    return tolerant(lambda: pole_lines(view), lambda: "")


def _listed_order(pole) -> tuple[float, float, float]:
    """The least damped first, then the slowest: damping and frequency compared to 9 digits, so
    that two modes of one damping (a launch vehicle's bending modes, zeta = 0.01 each) are listed
    by frequency whatever the last bits their eigenvalues come out with (a LAPACK build's
    rounding swapped them: -0.24 +- 24j before -0.11 +- 11j on one machine, after on another)."""
    return round(pole.zeta, 9), round(pole.wn, 9), pole.value.real


def pole_lines(view) -> str:
    """The current design's closed-loop poles of the first plotted condition (a conjugate pair
    once, as re +- im j) with zeta and wn, the least damped first; '' for a tabulated loop."""
    from engine.analysis import fixed_modes
    from engine.closed_loop.poles import polish, z_pole
    from engine.loop.realization import poles

    k = view.first_plotted
    c = _rational(view, k)
    ss = view.step_loop(k) if c is not None else None
    if ss is None:
        return ""
    params = view.parameters(None, k)
    try:
        found = poles(ss, lambda eig: polish(c.network, params, eig))
    except EngineError:
        found = poles(ss)
    hidden = fixed_modes(c.network, c.break_at, params, found)
    T = c.network.sample_time
    if T is not None:  # in z, with the damping and natural frequency of s = ln(z)/T
        found = [z_pole(p, T) for p in found]
    shown = sorted(((p, h) for p, h in zip(found, hidden) if p.value.imag >= 0), key=lambda ph: _listed_order(ph[0]))
    plane = "z" if T is not None else c.network.variable
    lines = [
        f"closed-loop poles ({c.name})" if len(view.problem.conditions) > 1 else "closed-loop poles",
        f"{'pole (z)' if plane == 'z' else 'pole':>22} {'zeta':>7} {'wn (w)' if plane == 'w' else 'wn rad/s':>10}",
    ]
    for p, h in shown[:MAX_POLES_LISTED]:
        value = f"{p.value.real:.5g}" + (f" +- {p.value.imag:.5g}j" if p.value.imag > 0 else "")
        lines.append(f"{value:>22} {p.zeta:>7.3g} {p.wn:>10.5g}" + (f"  fixed: {h} from the loop" if h else ""))
    if len(shown) > MAX_POLES_LISTED:
        lines.append(f"... {len(shown) - MAX_POLES_LISTED} more (the Poles plot shows them all)")
    return "\n".join(lines)

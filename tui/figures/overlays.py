"""The requirements drawn where the engineer looks (`tui.figures.requirements`): the
margins and the crossover band on Bode and Nichols, the Ms and Mt circles and the
margins' arcs on Nyquist, damping rays, settling and frequency bounds on the pole map
and the root locus, overshoot, times and the final-value band on the step plot.  A
requirement met is a gray line; one violated is red, its region shaded (░).  Each line's
legend entry names the target and its verdict."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from engine.model.bilinear import damping
from tui.figures.data import Figure, Handle, Series
from tui.figures.navigation import data_box
from tui.figures.open_loop import disk_edge, m_circle
from tui.figures.requirements import SHADE, Requirement

SHADE_GRID = (9, 3)  # shading points across and up a violated region


def _line(fig: Figure, x: Iterable[float], y: Iterable[float], req: Requirement, marker: str) -> None:
    points = list(map(float, x)), list(map(float, y))
    fig.series.append(Series(*points, req.label, marker=marker, beneath=True, **req.style))  # never over a curve


def _shade(fig: Figure, req: Requirement, x0: float, x1: float, y0: float, y1: float) -> None:
    """Points shading a region that violates ``req`` (nothing when it is met)."""
    if req.met is not False or not (x1 > x0 and y1 > y0):
        return
    across, up = SHADE_GRID
    xs, ys = np.meshgrid(np.linspace(x0, x1, across + 2)[1:-1], np.linspace(y0, y1, up + 2)[1:-1])
    shade = Series(xs.ravel().tolist(), ys.ravel().tolist(), "", marker=SHADE, scatter=True, color="red", beneath=True)
    fig.series.append(shade)


def _band(req: Requirement, x0: float, x1: float, scale: float) -> tuple[float, float] | None:
    """A band's frequencies as log10 x on a Bode axis, within [x0, x1] (None: outside)."""
    low = math.log10(req.low / scale) if req.low > 0 else -math.inf
    high = math.log10(req.high / scale) if math.isfinite(req.high) and req.high > 0 else math.inf
    low, high = max(low, x0), min(high, x1)
    return (low, high) if high > low else None


def _branch(phases: list[float], gains_db: list[float]) -> float:
    """The -180 deg (+- 360 k) nearest the phase where the gain is nearest 0 dB."""
    if not phases:
        return -180.0
    at = phases[int(np.nanargmin(np.abs(np.asarray(gains_db, dtype=float))))]
    return -180.0 + 360.0 * round((at + 180.0) / 360.0)


def bode(magnitude: Figure, phase: Figure, found: list[Requirement], unit: str) -> None:
    """GM and peak levels and the crossover bound on the magnitude, PM on the phase."""
    if magnitude.probe is None or phase.probe is None:
        return
    scale = 2 * math.pi if unit == "hz" else 1.0
    mx0, mx1, my0, my1 = data_box(magnitude)
    base = _branch(phase.probe.y, magnitude.probe.y)
    for req in found:
        band = _band(req, mx0, mx1, scale)
        if band is None:
            continue
        if req.measure == "gain_margin_db":
            _line(magnitude, band, [-req.value] * 2, req, "─")
            _shade(magnitude, req, *band, -req.value, max(0.0, -req.value))
        elif req.measure == "modal_peak_db":
            _line(magnitude, band, [req.value] * 2, req, "─")
            _shade(magnitude, req, *band, req.value, min(my1, req.value + 0.2 * (my1 - my0)))
        elif req.measure == "crossover_frequency" and req.value > 0:
            x = math.log10(req.value / scale)
            _line(magnitude, [x, x], [my0, my1], req, "│")
            left, right = (mx0, x) if req.at_least else (x, mx1)
            _shade(magnitude, req, left, right, -0.05 * (my1 - my0), 0.05 * (my1 - my0))
        elif req.measure == "phase_margin_deg":
            _line(phase, band, [base + req.value] * 2, req, "─")
            _shade(phase, req, *band, base, base + req.value)


class CompensatorRoot(NamedTuple):
    """A compensator's zero or pole (``kind``), its root (a pair's upper one) and the name
    of its item (block.item: what a drag moves; "" when it cannot be dragged)."""

    kind: str
    root: complex
    name: str


def corners(magnitude: Figure, roots: list[CompensatorRoot], unit: str, sample_time: float | None = None) -> None:
    """The compensator's corner frequencies on the Bode magnitude, on the current curve:
    z for a zero (or a pair of zeros), p for a pole, where the shaping table moves them (a
    root in z at the natural frequency |ln z|/T of its s-plane equivalent); each a handle
    the mouse drags along the frequency axis."""
    if magnitude.probe is None or not roots:
        return
    scale = 2 * math.pi if unit == "hz" else 1.0
    x, y = np.asarray(magnitude.probe.x), np.asarray(magnitude.probe.y)

    def corner(r: complex) -> float:
        return 0.0 if r == 0 else damping(r, sample_time)[1]  # in z: its s-plane equivalent's wn

    for kind, marker in (("zero", "z"), ("pole", "p")):
        at = [(math.log10(corner(r.root) / scale), r.name) for r in roots if r.kind == kind and corner(r.root) > 0]
        at = [(v, name) for v, name in at if x[0] <= v <= x[-1]]
        if at:
            xs = [v for v, _ in at]
            ys = np.interp(xs, x, y).tolist()
            magnitude.series.append(Series(xs, ys, f"compensator {kind}s", marker=marker, scatter=True))
            magnitude.handles += [Handle(v, h, name, "corner") for (v, name), h in zip(at, ys) if name]


def gain_drag(magnitude: Figure) -> None:
    """The Bode magnitude's curve dragged up or down moves the loop gain (dB for dB)."""
    if magnitude.probe is not None:
        magnitude.curve_motion = "gain"


def nyquist_frequency(magnitude: Figure, phase: Figure, sample_time: float | None, unit: str) -> None:
    """A sampled loop's Nyquist frequency pi/T, where its response ends, on both Bode plots."""
    if sample_time is None or magnitude.probe is None:
        return
    scale = 2 * math.pi if unit == "hz" else 1.0
    x = math.log10(math.pi / sample_time / scale)
    for fig in (magnitude, phase):
        low, high = _y_range(fig)
        label = f"Nyquist pi/T = {math.pi / sample_time / scale:.4g} {unit}" if fig is magnitude else ""
        fig.series.append(Series([x, x], [low, high], label, color="gray", marker="|", beneath=True))


def _y_range(fig: Figure) -> tuple[float, float]:
    ys = [v for s in fig.series for v in s.y if math.isfinite(v)]
    return (min(ys), max(ys)) if ys else (-1.0, 1.0)


def compensator_roots(fig: Figure, roots: list[CompensatorRoot]) -> None:
    """The compensator's zeros (z) and poles (p) on an s-plane figure (the pole map, the
    root locus), each pair with its conjugate: what the shaping table moves, and the
    mouse drags (each mark a handle)."""
    if not roots or not fig.series:
        return
    for kind, marker in (("zero", "z"), ("pole", "p")):
        at = [
            (r, c.name)
            for c in roots
            if c.kind == kind
            for r in ([c.root, c.root.conjugate()] if c.root.imag else [c.root])
        ]
        if at:
            fig.series.append(
                Series(
                    [r.real for r, _ in at],
                    [r.imag for r, _ in at],
                    f"compensator {kind}s",
                    marker=marker,
                    scatter=True,
                )
            )
            fig.handles += [Handle(r.real, r.imag, name, "root") for r, name in at if name]


def nichols(fig: Figure, found: list[Requirement]) -> None:
    """The PM/GM exclusion box about the critical point, and the M-circle of an Mt target."""
    if fig.probe is None:
        return
    base = _branch(fig.probe.x, fig.probe.y)
    pm = next((r for r in found if r.measure == "phase_margin_deg"), None)
    gm = next((r for r in found if r.measure == "gain_margin_db"), None)
    if pm is not None or gm is not None:
        half = pm.value if pm is not None else 0.0
        level = gm.value if gm is not None else 0.0
        worst = pm if pm is not None and pm.met is False else gm if gm is not None and gm.met is False else pm or gm
        x = [base - half, base + half, base + half, base - half, base - half]
        y = [-level, -level, level, level, -level]
        _line(fig, x, y, worst, "─")
        for req in (pm, gm):
            if req is not None and req is not worst:
                fig.series.append(Series([base], [0.0], req.label, marker="+", scatter=True, beneath=True, **req.style))
        _shade(fig, worst, base - half, base + half, -level, level)
    for req in found:
        if req.measure == "complementary_sensitivity_peak" and req.value > 0:
            ph, db = m_circle(20 * math.log10(req.value))
            _line(fig, ph + base + 180.0, db, req, "dot")


def nyquist(fig: Figure, found: list[Requirement]) -> None:
    """The Ms circle (|1 + GH| >= 1/Ms), the Mt circle, the GM segment of the negative real
    axis and the PM arc of the unit circle that GH must keep out of."""
    t = np.linspace(0, 2 * np.pi, 120)
    for req in found:
        if req.measure == "stability_margin" and req.value > 0:  # |1 + GH| >= r
            _line(fig, -1 + req.value * np.cos(t), req.value * np.sin(t), req, "dot")
        elif req.measure == "disk_margin" and req.value > 0:
            edge = disk_edge(req.value, t)
            _line(fig, edge.real, edge.imag, req, "dot")
        elif req.measure == "sensitivity_peak" and req.value > 0:
            r = 1.0 / req.value
            _line(fig, -1 + r * np.cos(t), r * np.sin(t), req, "dot")
        elif req.measure == "complementary_sensitivity_peak" and req.value > 1:
            m2 = req.value**2
            centre, r = -m2 / (m2 - 1), req.value / (m2 - 1)
            _line(fig, centre + r * np.cos(t), r * np.sin(t), req, "dot")
        elif req.measure == "gain_margin_db":
            _line(fig, [-1.0, -(10 ** (-req.value / 20))], [0.0, 0.0], req, "═")
        elif req.measure == "phase_margin_deg":
            arc = np.radians(np.linspace(180 - req.value, 180 + req.value, 40))
            _line(fig, np.cos(arc), np.sin(arc), req, "═")


def history(fig: Figure, kind: str, found: list[Requirement], unit: str, partner: Figure | None = None) -> None:
    """A History view's requirements (judged at its iteration): ``partner``, the other
    Bode plot of the pair (the phase for the magnitude and back)."""
    if kind == "nyquist":
        nyquist(fig, found)
    elif kind == "nichols":
        nichols(fig, found)
    elif kind in ("poles", "locus"):
        poles(fig, found)
    elif kind == "bode" and partner is not None:
        bode(fig, partner, found, unit)
    elif kind == "phase" and partner is not None:
        bode(partner, fig, found, unit)


def poles(fig: Figure, found: list[Requirement]) -> None:
    """The s-plane bounds of the time-response targets: the stability abscissa and the
    settling time as vertical lines, overshoot as damping rays, rise time as a natural
    frequency arc, peak time as a damped frequency line."""
    x0, x1, y0, y1 = data_box(fig)
    reach = max(abs(x0), abs(x1), abs(y0), abs(y1))
    for req in found:
        if req.measure == "stability_abscissa":
            _line(fig, [-req.value] * 2, [y0, y1], req, "│")
            _shade(fig, req, -req.value, max(x1, -req.value + 0.1 * reach), y0, y1)
        elif req.measure == "settling_time" and req.value > 0:
            sigma = -math.log(req.settling_band) / req.value  # a pole's envelope e^(-sigma t) inside the band
            _line(fig, [-sigma] * 2, [y0, y1], req, "│")
            _shade(fig, req, -sigma, min(0.0, x1), y0, y1)
        elif req.measure == "overshoot_percent" and 0 < req.value < 100:
            lo = math.log(req.value / 100)
            zeta = -lo / math.hypot(math.pi, lo)
            r = np.linspace(0, reach, 30)
            _line(fig, -zeta * r, math.sqrt(1 - zeta**2) * r, req, "╲")
            _line(fig, -zeta * r, -math.sqrt(1 - zeta**2) * r, req, "╱")
        elif req.measure == "rise_time" and req.value > 0:
            wn = 1.8 / req.value  # the 10-90 % rise of a second-order loop, about 1.8/wn
            arc = np.linspace(math.pi / 2, 3 * math.pi / 2, 60)
            _line(fig, wn * np.cos(arc), wn * np.sin(arc), req, "dot")
        elif req.measure == "peak_time" and req.value > 0:
            wd = math.pi / req.value
            _line(fig, [min(x0, -reach), 0.0], [wd, wd], req, "─")
            _line(fig, [min(x0, -reach), 0.0], [-wd, -wd], req, "─")


def step(fig: Figure, found: list[Requirement], final: float | None) -> None:
    """Overshoot and peak levels, the final-value band, and the rise, peak and settling
    times as vertical lines over the response."""
    if not fig.series:
        return
    x0, x1, y0, y1 = data_box(fig)
    for req in found:
        if req.measure == "overshoot_percent" and final is not None:
            level = final * (1 + req.value / 100)
            _line(fig, [x0, x1], [level, level], req, "─")
            _shade(fig, req, x0, x1, level, max(y1, level))
        elif req.measure == "peak_response":
            _line(fig, [x0, x1], [req.value, req.value], req, "─")
        elif req.measure == "steady_state_error" and final is not None:
            for level in (req.reference - req.value, req.reference + req.value):
                _line(fig, [x0 + 0.6 * (x1 - x0), x1], [level, level], req, "─")
        elif req.measure in ("rise_time", "settling_time", "peak_time") and x0 <= req.value <= x1:
            _line(fig, [req.value] * 2, [y0, y1], req, "│")
            if req.measure == "settling_time":
                _shade(fig, req, req.value, x1, y0, y1)
    if fig.ylim is not None:
        values = [v for s in fig.series for v in s.y if math.isfinite(v)]
        fig.ylim = (min(fig.ylim[0], *values), max(fig.ylim[1], *values)) if values else fig.ylim

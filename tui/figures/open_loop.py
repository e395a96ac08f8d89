"""The open loop's figures: Nyquist (with the mirror image at negative
frequencies, the unit circle, the stability circle and the disk-margin
exclusion disk), Bode with the margins marked, Nichols with M-circles."""

from __future__ import annotations

import math

import numpy as np

from tui.figures.axes import decade_ticks, finite_points
from tui.figures.data import Figure, Series, role_color, role_style
from tui.figures.navigation import loop_probe

M_CIRCLES_DB = (0.5, 1.0, 3.0, 6.0)  # |T| contours on the Nichols chart


def nyquist_figure(
    curves,
    points: list[tuple[complex, str]],
    title: str = "Nyquist (GH plane)",
    unit: str = "rad/s",
) -> Figure:
    """GH plane around -1: the curves (their mirror images at negative frequencies in
    gray), the unit circle, -1 and push/pull points (the targets' circles and disks are
    drawn with their verdicts: `tui.figures.overlays.nyquist`)."""
    fig = Figure(title=title, xlabel="Re GH", ylabel="Im GH", xlim=(-4.0, 2.0), ylim=(-3.0, 3.0))
    t = np.linspace(0, 2 * np.pi, 120)
    fig.series.append(Series(np.cos(t).tolist(), np.sin(t).tolist(), "", color="gray", beneath=True))
    for curve in curves:
        gh = np.clip(curve.gh.real, -50, 50) + 1j * np.clip(curve.gh.imag, -50, 50)
        x, y = finite_points(gh.real, gh.imag)
        fig.series.append(Series(x, [-v for v in y], "", color="gray", beneath=True))  # negative frequencies
        fig.series.append(Series(x, y, curve.label, **role_style(curve.role, curve.index)))
        if fig.probe is None:
            fig.probe = loop_probe(gh.real, gh.imag, curve.omega, curve.gh, unit, curve.on_branch)
    fig.series.append(Series([-1.0], [0.0], "-1", marker="x", scatter=True, color="red"))
    if points:
        fig.series.append(
            Series(
                [p.real for p, _ in points],
                [p.imag for p, _ in points],
                "push/pull points",
                marker="o",
                scatter=True,
                color="orange",
            )
        )
    return fig


def disk_edge(alpha: float, t: np.ndarray) -> np.ndarray:
    """The edge of a disk margin's exclusion disk in the GH plane (balanced, skew 0): the
    GH whose S = 1/(1 + GH) lies on |S - 1/2| = 1/alpha, at the angles ``t``."""
    s = 0.5 + np.exp(1j * t) / alpha
    with np.errstate(divide="ignore", invalid="ignore"):
        edge = 1.0 / s - 1.0
    return np.where(np.isfinite(edge) & (np.abs(edge) < 1e3), edge, np.nan)


def bode_figures(curves, unit: str, at: str = "") -> tuple[Figure, Figure]:
    """Magnitude (dB) and phase (deg) against log frequency; the current
    design's gain and phase margins marked at their frequencies; ``at`` ends the titles
    (the loop break drawn: ' at u_att')."""
    scale = 2 * np.pi if unit == "hz" else 1.0
    magnitude = Figure(title=f"Bode magnitude{at}", ylabel="dB", xlabel=f"frequency ({unit})", log_x=True)
    phase = Figure(title=f"Bode phase{at}", ylabel="deg", xlabel=f"frequency ({unit})", log_x=True)
    for curve in curves:
        w = curve.omega / scale
        positive = w > 0
        lw = np.log10(w[positive])
        gh = curve.gh[positive]
        with np.errstate(divide="ignore"):
            db = 20 * np.log10(np.abs(gh))
        degrees = np.degrees(np.unwrap(np.angle(gh)))
        magnitude.series.append(Series(*finite_points(lw, db), curve.label, **role_style(curve.role, curve.index)))
        phase.series.append(Series(*finite_points(lw, degrees), curve.label, **role_style(curve.role, curve.index)))
        if magnitude.probe is None:
            magnitude.probe = loop_probe(lw, db, curve.omega[positive], gh, unit, curve.on_branch)
            phase.probe = loop_probe(lw, degrees, curve.omega[positive], gh, unit, curve.on_branch)
        magnitude.xticks = phase.xticks = decade_ticks(lw)
        if curve.margins is not None:
            _mark_margins(magnitude, phase, curve, lw, degrees, scale)
    phase.legend = False  # the magnitude plot above it carries the legend
    return magnitude, phase


def _mark_margins(magnitude: Figure, phase: Figure, curve, lw: np.ndarray, degrees: np.ndarray, scale: float) -> None:
    """Phase margins at the gain crossovers (0 dB) and gain margins at the phase
    crossovers, on both plots; the legend gives the one nearest 0 of each kind."""
    prefix = "" if curve.label == "current" else f"{curve.label.split(':')[0]} "
    for kind, found in (("PM", curve.margins.phase), ("GM", curve.margins.listed("G"))):
        marks = [m for m in found if m.frequency > 0 and lw[0] <= math.log10(m.frequency / scale) <= lw[-1]]
        if not marks or not np.all(np.isfinite(degrees)):
            continue
        x = [math.log10(m.frequency / scale) for m in marks]
        if kind == "PM":  # the critical margin is the one nearest 0 (a lower gain margin is negative)
            level, worst = [0.0] * len(marks), f"{min((m.phase_deg for m in marks), key=abs):.1f} deg"
        else:
            level, worst = [-m.gain_db for m in marks], f"{min((m.gain_db for m in marks), key=abs):.1f} dB"
        label = f"{prefix}{kind} {worst}" + (f" ({len(marks)})" if len(marks) > 1 else "")
        marker = "x" if kind == "PM" else "o"
        magnitude.series.append(
            Series(x, level, label, marker=marker, scatter=True, color=role_color(curve.role, curve.index))
        )
        phase.series.append(
            Series(
                x,
                np.interp(x, lw, degrees).tolist(),
                label,
                marker=marker,
                scatter=True,
                color=role_color(curve.role, curve.index),
            )
        )


def nichols_figure(curves, unit: str = "rad/s", title: str = "Nichols") -> Figure:
    """Magnitude (dB) against phase (deg), with the critical point (-180 deg, 0 dB) and
    the M-circles |T| = M dB (`M_CIRCLES_DB`) about it."""
    fig = Figure(title=title, xlabel="phase (deg)", ylabel="dB")
    for k, m_db in enumerate(M_CIRCLES_DB):
        phase, db = m_circle(m_db)
        fig.series.append(
            Series(
                phase.tolist(),
                db.tolist(),
                "M " + ", ".join(f"{m:g}" for m in M_CIRCLES_DB) + " dB" if k == 0 else "",
                marker="∙",
                color="gray",
                beneath=True,
            )
        )
    for curve in curves:
        with np.errstate(divide="ignore"):
            db = 20 * np.log10(np.abs(curve.gh))
        degrees = np.degrees(np.unwrap(np.angle(curve.gh)))
        fig.series.append(Series(*finite_points(degrees, db), curve.label, **role_style(curve.role, curve.index)))
        if fig.probe is None:
            fig.probe = loop_probe(degrees, db, curve.omega, curve.gh, unit, curve.on_branch)
    fig.series.append(Series([-180.0], [0.0], "critical", marker="x", scatter=True, color="red"))
    return fig


def m_circle(m_db: float, points: int = 181) -> tuple[np.ndarray, np.ndarray]:
    """The Nichols contour |T| = |L/(1+L)| = M (dB): L = T/(1 - T) for T = M e^(j theta),
    as (phase in -360..0 deg, |L| in dB) in order along the contour, within +-40 dB."""
    m = 10 ** (m_db / 20)
    theta = np.linspace(-np.pi, np.pi, points)[1:-1]
    T = m * np.exp(1j * theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        L = T / (1 - T)
        db = 20 * np.log10(np.abs(L))
    phase = np.degrees(np.angle(L)) % -360.0
    keep = np.isfinite(db) & (db > -40) & (db < 40)
    return phase[keep], db[keep]

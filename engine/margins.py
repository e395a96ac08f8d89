"""Margins of an open loop GH(j omega), as in report 000 and classically.

Four kinds, each a distance (report 000, chapter II and the CIP listing):
  G  gain margin: where Im GH changes sign with Re GH < 0; value |1 + GH|;
  P  phase margin: where |GH| = 1; value |1 + GH| = 2 sin(|theta|/2);
  S  stability margin: local minimum of |1 + GH| over frequency;
  A  attenuation margin: local maximum of |GH| above a given frequency.
Classical forms ride along: gain margin in dB (-20 log10 |GH|), phase margin
in degrees (180 + angle GH, wrapped to (-180, 180]), delay margin.

Rational loops (`LoopModel.rational`) are searched over all frequencies on a
detection grid built from the blocks' corner frequencies (dense around lightly
damped poles and zeros), and every crossing or extremum is refined between
grid points to machine precision on the exact response, so no result depends
on the user's grid.  Loops with a delay are refined the same way within the
user's grid range.  Tabulated loops use the grid rule of the CIP listing
(subroutines GAINMG, PHASEM, SRMINS): the grid point nearest the sign change,
or the grid extremum; results then say ``method = "grid"``.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .loops import LoopModel
from .rootfind import refine_roots, sign_changes

POINTS_PER_DECADE = 10
CLUSTER = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])  # around a mode, in zeta*omega_n
LIGHT_DAMPING = 0.3
DECADES_BEYOND = 2.0
MAX_ROUNDS = 60
MAX_PHASE_STEP = np.radians(20.0)
PAIR_SAFETY = 1.5


@dataclass(frozen=True)
class Margin:
    """One margin: kind G, P, S or A; its frequency (rad/s) and distance value."""

    kind: str
    frequency: float
    value: float
    gh: complex
    gain_db: float | None = None
    phase_deg: float | None = None
    delay: float | None = None


@dataclass(frozen=True)
class Margins:
    """Every margin of one loop, sorted by frequency within each kind."""

    gain: tuple[Margin, ...]
    phase: tuple[Margin, ...]
    stability: tuple[Margin, ...]
    attenuation: tuple[Margin, ...]
    method: str  # "refined" or "grid"
    notes: tuple[str, ...] = field(default=())

    @property
    def crossover_frequency(self) -> float | None:
        """Gain crossover of the phase margin nearest 0 deg (python-control's wc)."""
        if not self.phase:
            return None
        return min(self.phase, key=lambda m: abs(m.phase_deg)).frequency

    @property
    def delay_margin(self) -> float | None:
        """Smallest added delay that puts a gain crossover on -1 (s); None with no crossover."""
        delays = [m.delay for m in self.phase if m.delay is not None]
        return min(delays) if delays else None

    def all(self) -> tuple[Margin, ...]:
        return self.gain + self.phase + self.stability + self.attenuation


@dataclass(frozen=True)
class Band:
    """A frequency band [low, high] in rad/s (high may be inf)."""

    low: float = 0.0
    high: float = float("inf")

    def contains(self, w: float) -> bool:
        return self.low <= w <= self.high


def margins(loop: LoopModel, gain_band: Band = Band(), phase_band: Band = Band(),
            attenuation_above: float | None = None) -> Margins:
    """All four margin kinds of ``loop`` (attenuation only when a frequency is given)."""
    if loop.evaluate is None:
        return _grid_margins(loop, gain_band, phase_band, attenuation_above)
    w, gh, dgh = detection_grid(loop)
    found = _refined(loop, w, gh, dgh)
    gain = [m for m in found["G"] if m.gh.real < 0]
    dc = loop.dc_value
    if loop.rational and dc is not None and dc.real < 0:
        gain = [_margin("G", 0.0, dc)] + gain
    notes = () if loop.rational else (
        f"searched within the grid {loop.omega[0]:.6g}..{loop.omega[-1]:.6g} rad/s",)
    above = float("inf") if attenuation_above is None else attenuation_above
    return Margins(
        gain=tuple(m for m in gain if gain_band.contains(m.frequency)),
        phase=tuple(m for m in found["P"] if phase_band.contains(m.frequency)),
        stability=tuple(found["S"]),
        attenuation=tuple(m for m in found["A"] if m.frequency >= above),
        method="refined", notes=notes)


def _refined(loop: LoopModel, w: NDArray, gh: NDArray, dgh: NDArray) -> dict[str, list[Margin]]:
    """Every crossing and extremum, refined in two passes.

    First the extrema: of |1 + GH| (S), of |GH| (A, and the minima too) and
    of the phase.  Between consecutive extrema of |GH| and of the phase, |GH|
    and arg GH are monotone, so inserting the extrema into the grid leaves at
    most one gain or phase crossover per interval: the second pass finds them.
    """
    extrema = {"S": (_slope_distance, 1), "A": (_slope_magnitude, -1), "Amin": (_slope_magnitude, 1),
               "phase": (_slope_phase, 0)}
    # an extremum can hide two crossings only where the level function has the
    # same sign at both ends: a minimum of |GH| above 1, a phase extremum short of
    # the negative real axis (|GH| maxima are margins of their own: all kept)
    im, mag = np.sign(gh.imag), np.abs(gh)
    relevant = {"Amin": (mag[:-1] > 1) & (mag[1:] > 1),
                "phase": (im[:-1] == im[1:]) & ((gh.real[:-1] < 0) | (gh.real[1:] < 0))}
    found_extrema = _refine_sign_changes(loop, w, gh, dgh, extrema, relevant)
    points = np.concatenate([found_extrema[k] for k in ("A", "Amin", "phase")])
    if points.size:
        g, dg = loop.evaluate(points)
        order = np.argsort(np.concatenate([w, points]), kind="stable")
        w, gh, dgh = (np.concatenate(p)[order] for p in ((w, points), (gh, g), (dgh, dg)))
    crossings = _refine_sign_changes(loop, w, gh, dgh, {"G": (_imag_sign, 0), "P": (_log_magnitude, 0)})
    every = {"G": crossings["G"], "P": crossings["P"], "S": found_extrema["S"], "A": found_extrema["A"]}
    frequencies = np.concatenate(list(every.values()))
    values = loop.evaluate(frequencies)[0] if frequencies.size else np.zeros(0)
    found: dict[str, list[Margin]] = {}
    start = 0
    for name, r in every.items():
        found[name] = [_margin(name, f, v) for f, v in zip(r, values[start:start + r.size])]
        start += r.size
    return found


def _refine_sign_changes(loop: LoopModel, w: NDArray, gh: NDArray, dgh: NDArray, functions: dict,
                         relevant: dict[str, NDArray] | None = None) -> dict[str, NDArray]:
    """Sorted roots of each function (direction +1 rising, -1 falling, 0 both), refined
    together; ``relevant[name]`` (per interval) limits which intervals are searched."""
    starts, kinds, exact = [], [], {}
    values = {name: f(gh, dgh) for name, (f, _) in functions.items()}
    for name, (_, direction) in functions.items():
        idx = sign_changes(values[name], rising_only=direction > 0, falling_only=direction < 0)
        if relevant and name in relevant:
            idx = idx[relevant[name][idx]]
        starts.append(idx)
        kinds.append(np.full(idx.size, name))
        exact[name] = w[np.flatnonzero(values[name] == 0)] if direction == 0 else np.zeros(0)
    idx, kind = np.concatenate(starts), np.concatenate(kinds)

    def fun(points: NDArray, which: NDArray) -> NDArray:
        g, dg = loop.evaluate(points)
        out = np.empty(points.size)
        for name, (f, _) in functions.items():
            sel = kind[which] == name
            if sel.any():
                out[sel] = f(g[sel], dg[sel])
        return out

    fa = np.array([values[k][i] for k, i in zip(kind, idx)])
    fb = np.array([values[k][i + 1] for k, i in zip(kind, idx)])
    roots = refine_roots(fun, w[idx], w[idx + 1], fa, fb) if idx.size else np.zeros(0)
    return {name: np.unique(np.concatenate([roots[kind == name], exact[name]])) for name in functions}


def detection_grid(loop: LoopModel) -> tuple[NDArray, NDArray, NDArray]:
    """Frequencies that resolve every feature of GH, with GH and dGH/domega there.

    Starts from a log-spaced background and a few points around every
    lightly damped corner, then halves every interval that could hide a
    minimum-maximum pair of |GH|, of |1 + GH| or of arg GH, or that steps
    more than 20 deg in phase.  Single extrema are found by their slope's
    sign change and inserted before crossings are sought (`_refined`).
    """
    w = _initial_grid(loop)
    gh, dgh = loop.evaluate(w)
    for _ in range(MAX_ROUNDS):
        split = _needs_split(w, gh, dgh)
        if not split.any():
            break
        i = np.flatnonzero(split)
        mid = np.where(w[i] > 0, np.sqrt(w[i] * w[i + 1]), 0.5 * w[i + 1])
        gm, dgm = loop.evaluate(mid)
        order = np.argsort(np.concatenate([w, mid]), kind="stable")
        w = np.concatenate([w, mid])[order]
        gh, dgh = np.concatenate([gh, gm])[order], np.concatenate([dgh, dgm])[order]
    return w, gh, dgh


def _needs_split(w: NDArray, gh: NDArray, dgh: NDArray) -> NDArray[np.bool_]:
    """Intervals that could hide a crossing or extremum pair, or step too far in phase."""
    with np.errstate(all="ignore"):
        phase_step = np.abs(np.angle(gh[1:] / gh[:-1]))
        coarse = (phase_step > MAX_PHASE_STEP) | _may_hide_pair(gh + 1.0, dgh) | _may_hide_pair(gh, dgh) \
            | _may_hide_phase_pair(gh, dgh)
    resolvable = (w[1:] - w[:-1]) > 1e-12 * w[1:]
    return coarse & resolvable & np.isfinite(gh[1:]) & np.isfinite(gh[:-1])


def _may_hide_pair(r: NDArray, dr: NDArray) -> NDArray[np.bool_]:
    """Could the distance |r| have a minimum and a maximum inside an interval?

    d|r|/domega changes sign where the tangent dr is perpendicular to r, i.e.
    where the angle phi between them crosses 90 deg.  With both ends on the same
    side, two crossings need phi to vary by the sum of the ends' distances to
    90 deg; phi varies by at most the turn of the tangent plus the turn of r.
    """
    phi = np.abs(np.angle(dr / r))
    to_right_angle = np.abs(np.pi / 2 - phi)
    variation = np.abs(np.angle(dr[1:] / dr[:-1])) + np.abs(np.angle(r[1:] / r[:-1]))
    same_side = (phi[1:] < np.pi / 2) == (phi[:-1] < np.pi / 2)
    return same_side & (PAIR_SAFETY * variation > to_right_angle[1:] + to_right_angle[:-1])


def _may_hide_phase_pair(r: NDArray, dr: NDArray) -> NDArray[np.bool_]:
    """Could the phase of r have a maximum and a minimum inside an interval?

    d(arg r)/domega changes sign where the tangent dr is parallel to r: the
    signed angle theta between them crosses 0 or 180 deg.  Same test as
    `_may_hide_pair`, with the distance to the nearer of 0 and 180 deg.
    """
    theta = np.angle(dr / r)
    to_radial = np.minimum(np.abs(theta), np.pi - np.abs(theta))
    variation = np.abs(np.angle(dr[1:] / dr[:-1])) + np.abs(np.angle(r[1:] / r[:-1]))
    same_side = (theta[1:] > 0) == (theta[:-1] > 0)
    return same_side & (PAIR_SAFETY * variation > to_radial[1:] + to_radial[:-1])


def _initial_grid(loop: LoopModel) -> NDArray[np.float64]:
    corners = loop.corner_frequencies
    if loop.rational:
        lo = corners.min() if corners.size else 1.0
        hi = corners.max() if corners.size else 1.0
        lo, hi = _extend_to_crossovers(loop, lo * 10.0 ** -DECADES_BEYOND, hi * 10.0 ** DECADES_BEYOND)
    else:
        lo, hi = loop.omega[0], loop.omega[-1]
        lo = lo if lo > 0 else min(loop.omega[1] * 1e-3, 1e-6)
    n = max(int(np.ceil(np.log10(hi / lo) * POINTS_PER_DECADE)), 2)
    parts = [np.geomspace(lo, hi, n)]
    light = loop.dampings < LIGHT_DAMPING
    for wn, zeta in zip(corners[light], loop.dampings[light]):
        offsets = CLUSTER if zeta > 0 else CLUSTER[CLUSTER != 0]
        parts.append(wn * (1.0 + max(zeta, 1e-9) * offsets))
    if not loop.rational:
        parts.append(loop.omega[loop.omega > 0])
    w = np.unique(np.concatenate(parts))
    return w[(w >= lo) & (w <= hi)]


def _extend_to_crossovers(loop: LoopModel, lo: float, hi: float) -> tuple[float, float]:
    """Move each end out by decades while |GH| still moves towards (or across) 1 beyond it."""

    def keeps_going(end: float, beyond: float) -> bool:
        with np.errstate(all="ignore"):
            f0, f1 = np.log(np.abs(loop.evaluate(np.array([end, beyond]))[0]))
        if not (np.isfinite(f0) and np.isfinite(f1)):
            return False
        return f0 * f1 <= 0 or abs(f1) < abs(f0) - 1e-6

    for _ in range(40):
        if not keeps_going(hi, hi * 10.0):
            break
        hi *= 10.0
    for _ in range(40):
        if not keeps_going(lo, lo / 10.0):
            break
        lo /= 10.0
    return lo, hi


def _margin(kind: str, w: float, gh: complex) -> Margin:
    """A margin with its distance value and, for G and P, the classical forms."""
    gh, w = complex(gh), float(w)
    distance = abs(1.0 + gh)
    if kind == "G":
        db = -20.0 * math.log10(abs(gh)) if gh != 0 else math.inf
        return Margin("G", w, distance, gh, gain_db=db)
    if kind == "P":
        phase = 180.0 + math.degrees(cmath.phase(gh))
        phase = phase - 360.0 if phase > 180.0 else phase
        lag = math.radians(phase) % (2 * math.pi)
        return Margin("P", w, distance, gh, phase_deg=phase, delay=lag / w if w > 0 else None)
    return Margin(kind, w, distance if kind == "S" else abs(gh), gh)


def _imag_sign(gh: NDArray, dgh: NDArray | None = None) -> NDArray:
    return gh.imag / np.abs(gh)


def _log_magnitude(gh: NDArray, dgh: NDArray | None = None) -> NDArray:
    return np.log(np.abs(gh))


def _slope_distance(gh: NDArray, dgh: NDArray) -> NDArray:
    """Sign of d|1 + GH|/domega, scaled to be O(1)."""
    return np.real(np.conj(1.0 + gh) * dgh) / (np.abs(1.0 + gh) * np.abs(dgh) + 1e-300)


def _slope_phase(gh: NDArray, dgh: NDArray) -> NDArray:
    """Sign of d(arg GH)/domega, scaled to be O(1)."""
    return np.imag(dgh / gh) / (np.abs(dgh / gh) + 1e-300)


def _slope_magnitude(gh: NDArray, dgh: NDArray) -> NDArray:
    """Sign of d|GH|/domega, scaled to be O(1)."""
    return np.real(np.conj(gh) * dgh) / (np.abs(gh) * np.abs(dgh) + 1e-300)


def _grid_margins(loop: LoopModel, gain_band: Band, phase_band: Band,
                  attenuation_above: float | None) -> Margins:
    """The CIP listing's grid rules (GAINMG, PHASEM, SRMINS) on the user's grid."""
    w, gh = loop.omega, loop.gh
    im, mag2 = gh.imag, np.abs(gh) ** 2

    def nearest(f: NDArray, i: NDArray) -> NDArray:
        return np.where(np.abs(f[i + 1]) < np.abs(f[i]), i + 1, i)

    gi = sign_changes(im)
    gi = nearest(im, gi[gh.real[gi + 1] < 0])  # GAINMG tests Re GH at the later point
    pi = nearest(mag2 - 1.0, sign_changes(mag2 - 1.0))
    dist2 = np.abs(1.0 + gh) ** 2
    si = sign_changes(np.diff(dist2), rising_only=True) + 1
    ai = sign_changes(np.diff(mag2), falling_only=True) + 1
    return Margins(
        gain=tuple(_margin("G", w[i], gh[i]) for i in gi if gain_band.contains(w[i])),
        phase=tuple(_margin("P", w[i], gh[i]) for i in pi if phase_band.contains(w[i])),
        stability=tuple(_margin("S", w[i], gh[i]) for i in si),
        attenuation=tuple(_margin("A", w[i], gh[i]) for i in ai
                          if attenuation_above is not None and w[i] > attenuation_above),
        method="grid",
        notes=("tabulated loop: margins at grid points (report 000 grid rule), not refined",))

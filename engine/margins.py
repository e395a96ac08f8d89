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

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .loops import LoopModel
from .rootfind import Roots, refine, sign_changes

POINTS_PER_DECADE = 10
CLUSTER = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])  # around a mode, in zeta*omega_n
LIGHT_DAMPING = 0.3
DECADES_BEYOND = 2.0
DECADES_PER_LOOK = 8
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
    """Every crossing and extremum, refined together in one vectorized loop.

    The detection grid leaves at most one extremum of |GH|, of |1 + GH| and
    of arg GH in an interval, so an interval whose ends differ in sign holds
    exactly one crossing, and one whose ends agree holds two or none: two
    when the extremum inside lies across the level.  Those extrema are
    watched while they are refined (`refine`'s ``hiding``): extrema of |GH|
    for gain crossovers, extrema of the phase for phase crossovers.
    """
    brackets = _grid_brackets(w, gh, dgh)
    names = list(brackets)
    index = np.concatenate([brackets[name].index for name in names])
    counts = [brackets[name].index.size for name in names]
    roots = _refine(loop, (w[index], gh[index], dgh[index]), (w[index + 1], gh[index + 1], dgh[index + 1]),
                    [LEVELS[name] for name in names], counts)
    bounds = np.cumsum([0] + counts)
    frequencies = {name: roots.at[start:stop] for name, start, stop in zip(names, bounds[:-1], bounds[1:])}
    for name, start, stop in zip(names, bounds[:-1], bounds[1:]):
        crossing = LEVELS[name].reveals
        if crossing:
            hidden = roots.hidden[start:stop].ravel()
            frequencies[crossing] = np.concatenate([frequencies[crossing], hidden[~np.isnan(hidden)]])
    values = _evaluated(loop, {name: frequencies[name] for name in ("G", "P", "S", "A")})
    margins: dict[str, list[Margin]] = {}
    for name in ("G", "P", "S", "A"):
        points = np.concatenate([frequencies[name], w[brackets[name].exact]])
        at = np.concatenate([values[name], gh[brackets[name].exact]])
        unique, first = np.unique(points, return_index=True)
        margins[name] = _margins_of(name, unique, at[first])
    return margins


@dataclass(frozen=True)
class Level:
    """A level function of GH and its slope h' (from dGH/domega).

    Magnitudes: h = log |GH + shift| (shift 0: |GH|, 1: the distance to -1),
    h' = Re(dGH / (GH + shift)).  Angles: h = the angle of GH from the
    negative real axis, continued from the bracket's left end (so it is
    continuous across the axis and 0 on it), h' = Im(dGH / GH).
    """

    shift: float
    angle: bool
    stationary: bool  # an extremum (a root of h') rather than a crossing (a root of h)
    direction: int  # of the target's sign change: +1 rising, -1 falling, 0 either
    reveals: str = ""  # extrema: the crossing of h that may hide on either side (see `_refined`)

    @property
    def watched(self) -> bool:
        return bool(self.reveals)


LEVELS = {"S": Level(1.0, False, True, 1), "A": Level(0.0, False, True, -1, "P"),
          "Amin": Level(0.0, False, True, 1, "P"), "phase": Level(0.0, True, True, 0, "G"),
          "G": Level(0.0, True, False, 0), "P": Level(0.0, False, False, 0)}


@dataclass(frozen=True)
class Brackets:
    """Grid intervals [w[index], w[index + 1]] holding a root of one level,
    and grid points where its target is exactly 0 (``exact``)."""

    index: NDArray[np.intp]
    exact: NDArray[np.intp]


def _grid_brackets(w: NDArray, gh: NDArray, dgh: NDArray) -> dict[str, Brackets]:
    """Per level, the intervals where its target (h' for extrema, h for
    crossings) changes sign in its direction.  Kept only where they matter:
    minima of |GH| and extrema of the phase that may hide two crossings
    (minima above 1; phase extrema short of the negative real axis), gain
    crossings on the negative real axis."""
    with np.errstate(all="ignore"):
        relative, distance = dgh / gh, dgh / (1.0 + gh)
    im, mag = np.sign(gh.imag), np.abs(gh)
    negative = (gh.real[:-1] < 0) | (gh.real[1:] < 0)
    targets = {"S": distance.real, "A": relative.real, "Amin": relative.real, "phase": relative.imag,
               "G": gh.imag, "P": mag - 1.0}
    keep = {"Amin": (mag[:-1] > 1) & (mag[1:] > 1), "phase": (im[:-1] == im[1:]) & negative, "G": negative}
    out = {}
    for name, level in LEVELS.items():
        target = targets[name]
        index = sign_changes(target, rising_only=level.direction > 0, falling_only=level.direction < 0)
        if name in keep:
            index = index[keep[name][index]]
        exact = np.flatnonzero(target == 0) if level.direction == 0 else np.zeros(0, dtype=np.intp)
        if name == "G":
            exact = exact[gh.real[exact] < 0]
        out[name] = Brackets(index, exact)
    return out


def _level_values(g: NDArray, dg: NDArray, shift: NDArray, left: NDArray, offset: NDArray,
                  angle: NDArray) -> tuple[NDArray, NDArray]:
    """(h, h') of each point's own level (see `Level`): ``left`` is the
    bracket's left-end GH for angles (1 for magnitudes), ``offset`` the
    angle of that end from the negative real axis (0 for magnitudes)."""
    with np.errstate(all="ignore"):
        base = g + shift
        turned, ratio = base / left, dg / base
        h = np.where(angle, np.arctan2(turned.imag, turned.real) + offset, np.log(np.abs(base)))
    return h, np.where(angle, ratio.imag, ratio.real)


def _refine(loop: LoopModel, lo: tuple, hi: tuple, levels: list[Level], counts: list[int]) -> Roots:
    """`refine` on brackets given by their ends' (omega, GH, dGH), ``counts[k]``
    of them on ``levels[k]``."""

    def each(field: str, dtype: type) -> NDArray:
        return np.repeat(np.array([getattr(level, field) for level in levels], dtype=dtype), counts)

    shift, angle = each("shift", float), each("angle", bool)
    left = np.where(angle, lo[1], 1.0)
    offset = np.where(angle, np.angle(-lo[1]), 0.0)

    def fun(points: NDArray, which: NDArray) -> tuple[NDArray, NDArray]:
        return _level_values(*loop.evaluate(points), shift[which], left[which], offset[which], angle[which])

    ha, da = _level_values(lo[1], lo[2], shift, left, offset, angle)
    hb, db = _level_values(hi[1], hi[2], shift, left, offset, angle)
    return refine(fun, lo[0], hi[0], ha, hb, da, db, each("stationary", bool), each("watched", bool))


def _evaluated(loop: LoopModel, frequencies: dict[str, NDArray]) -> dict[str, NDArray]:
    """GH at every level's frequencies, in one evaluation."""
    every = np.concatenate(list(frequencies.values()))
    values = loop.evaluate(every)[0] if every.size else np.zeros(0, dtype=complex)
    out, start = {}, 0
    for name, points in frequencies.items():
        out[name], start = values[start:start + points.size], start + points.size
    return out


def detection_grid(loop: LoopModel) -> tuple[NDArray, NDArray, NDArray]:
    """Frequencies that resolve every feature of GH, with GH and dGH/domega there.

    Starts from a log-spaced background and a few points around every
    lightly damped corner, then halves every interval that could hide a
    minimum-maximum pair of |GH|, of |1 + GH| or of arg GH, or that steps
    more than 20 deg in phase (each round tests only the new halves).
    Single extrema are found by their slope's sign change and refined with
    the crossings (`_refined`).
    """
    w = _initial_grid(loop)
    points = _with_curve(w, *loop.evaluate(w))
    found = [points]
    split = _needs_split(points[:, :-1], points[:, 1:])
    starts, stops = points[:, :-1][:, split], points[:, 1:][:, split]
    for _ in range(MAX_ROUNDS):
        if starts.shape[1] == 0:
            break
        a, b = starts[0].real, stops[0].real
        mid = np.where(a > 0, np.sqrt(a * b), 0.5 * b)
        middle = _with_curve(mid, *loop.evaluate(mid))
        found.append(middle)
        starts = np.concatenate([starts, middle], axis=1)  # left halves, then right halves
        stops = np.concatenate([middle, stops], axis=1)
        split = _needs_split(starts, stops)
        starts, stops = starts[:, split], stops[:, split]
    points = np.concatenate(found, axis=1)
    points = points[:, np.argsort(points[0].real, kind="stable")]
    return points[0].real, points[1], points[3]


def _with_curve(w: NDArray, gh: NDArray, dgh: NDArray) -> NDArray[np.complex128]:
    """Rows omega, GH, 1 + GH, dGH/domega: the points of the detection grid."""
    return np.array([w, gh, 1.0 + gh, dgh])


def _needs_split(start: NDArray, stop: NDArray) -> NDArray[np.bool_]:
    """Intervals (ends: columns of `_with_curve` rows) that could hide a
    crossing or extremum pair, or step too far in phase.

    Row by row: the turns of GH, 1 + GH and the tangent dGH over each
    interval, and at each end the angles theta of the tangent against GH
    and phi against 1 + GH (see `_may_hide_pair`)."""
    with np.errstate(all="ignore"):
        turns = np.abs(_angle(stop[1:] / start[1:]))  # GH, 1 + GH, tangent
        angles0, angles1 = _angle(start[3] / start[1:3]), _angle(stop[3] / stop[1:3])  # theta, phi
        variation = turns[2] + turns[:2]
        pair = _may_hide_pair(angles0, angles1, variation)  # of |GH|, of |1 + GH|
        coarse = (turns[0] > MAX_PHASE_STEP) | pair[0] | pair[1] | _may_hide_phase_pair(angles0[0], angles1[0], variation[0])
    w0, w1 = start[0].real, stop[0].real
    resolvable = (w1 - w0) > 1e-12 * w1
    return coarse & resolvable & np.isfinite(start[1]) & np.isfinite(stop[1])


def _angle(z: NDArray) -> NDArray:
    """np.angle without its Python wrapper (this is a hot path)."""
    return np.arctan2(z.imag, z.real)


def _may_hide_pair(angle0: NDArray, angle1: NDArray, variation: NDArray) -> NDArray[np.bool_]:
    """Could a distance |r| have a minimum and a maximum inside an interval?

    d|r|/domega changes sign where the tangent dr is perpendicular to r, i.e.
    where the angle between them (given signed at both ends) crosses +-90
    deg.  With both ends on the same side, two crossings need its size to
    vary by the sum of the ends' distances to 90 deg; it varies by at most
    ``variation``: the turn of the tangent plus the turn of r.
    """
    size0, size1 = np.abs(angle0), np.abs(angle1)
    same_side = (size1 < np.pi / 2) == (size0 < np.pi / 2)
    return same_side & (PAIR_SAFETY * variation > np.abs(np.pi / 2 - size0) + np.abs(np.pi / 2 - size1))


def _may_hide_phase_pair(theta0: NDArray, theta1: NDArray, variation: NDArray) -> NDArray[np.bool_]:
    """Could the phase of r have a maximum and a minimum inside an interval?

    d(arg r)/domega changes sign where the tangent dr is parallel to r: the
    signed angle theta between them crosses 0 or 180 deg.  Same test as
    `_may_hide_pair`, with the distance to the nearer of 0 and 180 deg.
    """
    to_radial0 = np.minimum(np.abs(theta0), np.pi - np.abs(theta0))
    to_radial1 = np.minimum(np.abs(theta1), np.pi - np.abs(theta1))
    same_side = (theta1 > 0) == (theta0 > 0)
    return same_side & (PAIR_SAFETY * variation > to_radial0 + to_radial1)


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
    background = np.exp(np.linspace(math.log(lo), math.log(hi), n))
    background[0], background[-1] = lo, hi
    parts = [background]
    light = loop.dampings < LIGHT_DAMPING
    wn, zeta = corners[light, None], loop.dampings[light, None]
    cluster = wn * (1.0 + np.maximum(zeta, 1e-9) * CLUSTER)
    parts.append(cluster[(zeta > 0) | (CLUSTER != 0)])  # not on an undamped corner itself
    if not loop.rational:
        parts.append(loop.omega[loop.omega > 0])
    w = np.unique(np.concatenate(parts))
    return w[(w >= lo) & (w <= hi)]


def _extend_to_crossovers(loop: LoopModel, lo: float, hi: float) -> tuple[float, float]:
    """Move each end out by decades while |GH| still moves towards (or across) 1
    beyond it (up to 40 decades; eight at a time, both ends in one evaluation)."""
    steps = 10.0 ** np.arange(DECADES_PER_LOOK + 1)
    for _ in range(40 // DECADES_PER_LOOK):
        with np.errstate(all="ignore"):
            level = np.log(np.abs(loop.evaluate(np.concatenate([hi * steps, lo / steps]))[0]))
        up, down = _decades_moving(level[:steps.size]), _decades_moving(level[steps.size:])
        hi, lo = hi * 10.0 ** up, lo / 10.0 ** down
        if up < DECADES_PER_LOOK and down < DECADES_PER_LOOK:
            break
    return lo, hi


def _decades_moving(level: NDArray) -> int:
    """How many steps in a row log |GH| keeps moving towards (or across) 0."""
    values = level.tolist()  # plain floats: numpy scalars are slow in a Python loop
    for k in range(len(values) - 1):
        f0, f1 = values[k], values[k + 1]
        if not (math.isfinite(f0) and math.isfinite(f1) and (f0 * f1 <= 0 or abs(f1) < abs(f0) - 1e-6)):
            return k
    return len(values) - 1


def _margin(kind: str, w: float, gh: complex) -> Margin:
    """A margin with its distance value and, for G and P, the classical forms."""
    return _margins_of(kind, np.array([w], dtype=float), np.array([gh], dtype=complex))[0]


def _margins_of(kind: str, w: NDArray, gh: NDArray) -> list[Margin]:
    """Margins of one kind at frequencies ``w`` where the loop is ``gh``:
    distance values and, for G and P, the classical forms (dB; degrees
    wrapped to (-180, 180] and the delay margin)."""
    with np.errstate(all="ignore"):
        magnitude, distance = np.abs(gh), np.abs(1.0 + gh)
        if kind == "G":
            db = np.where(magnitude > 0, -20.0 * np.log10(magnitude), np.inf)
            return [Margin("G", f, d, g, gain_db=x) for f, d, g, x in zip(w.tolist(), distance.tolist(), gh.tolist(),
                                                                           db.tolist())]
        if kind == "P":
            phase = 180.0 + np.degrees(np.arctan2(gh.imag, gh.real))
            phase = np.where(phase > 180.0, phase - 360.0, phase)
            delay = np.radians(phase) % (2 * np.pi) / w
            return [Margin("P", f, d, g, phase_deg=x, delay=t if f > 0 else None)
                    for f, d, g, x, t in zip(w.tolist(), distance.tolist(), gh.tolist(), phase.tolist(), delay.tolist())]
    values = distance if kind == "S" else magnitude
    return [Margin(kind, f, v, g) for f, v, g in zip(w.tolist(), values.tolist(), gh.tolist())]


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
    gi = gi[np.array([gain_band.contains(w[i]) for i in gi], dtype=bool)]
    pi = pi[np.array([phase_band.contains(w[i]) for i in pi], dtype=bool)]
    ai = ai[w[ai] > attenuation_above] if attenuation_above is not None else ai[:0]
    return Margins(
        gain=tuple(_margins_of("G", w[gi], gh[gi])), phase=tuple(_margins_of("P", w[pi], gh[pi])),
        stability=tuple(_margins_of("S", w[si], gh[si])), attenuation=tuple(_margins_of("A", w[ai], gh[ai])),
        method="grid",
        notes=("tabulated loop: margins at grid points (report 000 grid rule), not refined",))

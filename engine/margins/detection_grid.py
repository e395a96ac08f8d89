"""The detection grid of the margin search: frequencies that resolve every
feature of an open loop GH(j omega), with GH and dGH/domega there.

It starts from a log-spaced background between the blocks' corners
(extended while |GH| still moves towards 1), a few points around every
lightly damped corner and, for a loop with delays, a linear grid of
`POINTS_PER_HALF_TURN` points per pi/tau of frequency (the phase of
exp(-j omega tau) turns by pi there).  Then every interval that could hide a
minimum-maximum pair of |GH|, of |1 + GH| or of arg GH, or that steps more
than 20 deg in phase, is halved (each round tests only the new halves).

Every search is bounded: the grid has a budget of points derived from the
loop (`point_budget`: its corners and delays) and at most `MAX_ROUNDS`
rounds of halving; when either bites, the search stops and says so in
``notes``.  A level that is constant over the whole grid (|1 + GH| of an
all-pass loop such as 2/(s - 1), |GH| of one, the phase of s**9) has no
interior extremum: it is reported in ``flat`` and never split for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from weakref import WeakKeyDictionary

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.loop.responses import LoopModel

POINTS_PER_DECADE = 20  # 10 missed shallow minima of |1 + GH| hidden with a maximum in one interval
CLUSTER = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])  # around a mode, in zeta*omega_n
LIGHT_DAMPING = 0.3
DECADES_BEYOND = 2.0
FIRST_TURN = 0.1  # rad of a delay's phase: a delay loop is searched from omega tau = this, below its first half-turn
LOWEST_HALF_TURNS = 24  # ... up to omega tau = this times pi at least: the 10 lowest gain margins
RANGE = (1e-300, 1e300)  # the frequencies any search stays within (rad/s)
DECADES_PER_LOOK = 8
MAX_ROUNDS = 60
MAX_PHASE_STEP = np.radians(20.0)
PAIR_SAFETY = 1.5
POINTS_PER_HALF_TURN = 10  # of a delay's phase: 18 deg per interval
BASE_BUDGET = 20_000
BUDGET_PER_CORNER = 2_000
MAX_BUDGET = 100_000  # 4 complex rows: 6.4 MB, whatever the loop
DELAY_BUDGET = MAX_BUDGET // 2  # of them for a delay's linear grid (5000 half-turns of its phase)
FLAT = 1e-9  # a level whose log varies less than this over the grid is constant
SHALLOW = 1e-4  # ... less than this: too shallow to hide a pair worth splitting for
NOISE = 1e-11  # relative size below which a level's value or slope is rounding noise
STATIONARY = 1e-3  # rad from 90 deg at both ends: |r| is stationary there (an arc about the origin)
UNDAMPED = 1e-9  # a corner this lightly damped is on the imaginary axis (roots of an expanded polynomial)
TURN_NOISE = 1e-10  # rad: a curve that turns less than this over an interval is straight


@dataclass(frozen=True)
class Detection:
    """The grid (sorted), GH and dGH/domega on it, which levels are constant
    (``"GH"``: |GH|; ``"1+GH"``: |1 + GH|; ``"phase"``: arg GH), and notes."""

    omega: NDArray[np.float64]
    gh: NDArray[np.complex128]
    dgh: NDArray[np.complex128]
    flat: frozenset[str] = frozenset()
    shallow: frozenset[str] = frozenset()
    notes: tuple[str, ...] = field(default=())
    crossovers_beyond: float | None = (
        None  # a delay loop's search stopped here with |GH| >= 1: crossovers may lie above
    )


def point_budget(loop: LoopModel, searched: tuple[float, float] | None) -> int:
    """Most points the grid may hold: a base, more per corner, more per delay
    half-turn over the ``searched`` range of a delay loop (capped at `MAX_BUDGET`)."""
    budget = BASE_BUDGET + BUDGET_PER_CORNER * int(loop.corner_frequencies.size)
    delay = min(DELAY_BUDGET, _delay_points(loop, *searched)[0]) if searched is not None else 0
    return min(MAX_BUDGET, budget + delay)


_GRIDS: WeakKeyDictionary[LoopModel, Detection] = WeakKeyDictionary()


def detection_grid(loop: LoopModel, seed: NDArray[np.float64] | None = None) -> Detection:
    """Frequencies that resolve every feature of GH (see the module docstring);
    kept for the loop's lifetime (margins and closed-loop peaks share it).
    ``seed``: frequencies to start from instead of the background grid (the
    detection grid of a close form of the same loop: its intervals are tested
    and halved on this loop as any are, so the grid resolves this loop's
    features all the same, in fewer rounds)."""
    found = _GRIDS.get(loop)
    if found is None:
        found = _GRIDS[loop] = _detection_grid(loop, seed)
    return found


def _detection_grid(loop: LoopModel, seed: NDArray[np.float64] | None = None) -> Detection:
    searched = None if loop.rational else _searched_range(loop)  # its extension evaluates GH: once
    budget = point_budget(loop, searched)
    notes: list[str] = []
    w = _initial_grid(loop, budget, notes, searched)
    if seed is not None:
        w = np.union1d(w, seed[(seed >= w[0]) & (seed <= w[-1])])
    points = _with_curve(w, *loop.evaluate(w))
    flat, shallow = _flat_levels(points)
    found, total = [points], w.size
    split = _needs_split(points[:, :-1], points[:, 1:], shallow)
    starts, stops = points[:, :-1][:, split], points[:, 1:][:, split]
    for _ in range(MAX_ROUNDS):
        if starts.shape[1] == 0:
            break
        if total + starts.shape[1] > budget:
            notes.append(
                f"the detection grid reached its budget of {budget} points: features narrower "
                f"than its spacing near {_where(starts):.6g} rad/s may be missed"
            )
            break
        a, b = starts[0].real, stops[0].real
        mid = np.where(a > 0, np.sqrt(a * b), 0.5 * b)
        middle = _with_curve(mid, *loop.evaluate(mid))
        found.append(middle)
        total += mid.size
        starts = np.concatenate([starts, middle], axis=1)  # left halves, then right halves
        stops = np.concatenate([middle, stops], axis=1)
        split = _needs_split(starts, stops, shallow)
        starts, stops = starts[:, split], stops[:, split]
    else:
        if starts.shape[1]:
            notes.append(f"the detection grid stopped after {MAX_ROUNDS} rounds of halving")
    points = np.concatenate(found, axis=1)
    points = points[:, np.argsort(points[0].real, kind="stable")]
    top = float(points[0, -1].real)
    cut = searched is not None and loop.delay > 0 and top < searched[1]
    beyond = top if cut and abs(points[1, -1]) >= 1.0 else None
    return Detection(points[0].real, points[1], points[3], frozenset(flat), frozenset(shallow), tuple(notes), beyond)


def _where(starts: NDArray) -> float:
    return float(np.median(starts[0].real))


def _with_curve(w: NDArray, gh: NDArray, dgh: NDArray) -> NDArray[np.complex128]:
    """Rows omega, GH, 1 + GH, dGH/domega: the points of the detection grid."""
    return np.array([w, gh, 1.0 + gh, dgh])


def _flat_levels(points: NDArray) -> tuple[set[str], set[str]]:
    """Levels constant over the whole grid (log |GH|, log |1 + GH| or arg GH
    varying by less than `FLAT`, and their slopes rounding noise), and
    magnitudes shallow enough (`SHALLOW`) that no pair is split for."""
    flat, shallow = set(), set()
    with np.errstate(all="ignore"):
        for name, row in (("GH", points[1]), ("1+GH", points[2])):
            finite = np.isfinite(row) & (row != 0)
            if not np.all(finite):
                continue
            level = np.log(np.abs(row))
            slope = (points[3] / row).real * points[0].real
            if np.ptp(level) < FLAT and np.max(np.abs(slope)) < FLAT:
                flat.add(name)
            if np.ptp(level) < SHALLOW:
                shallow.add(name)
        gh = points[1]
        if np.all(np.isfinite(gh) & (gh != 0)):
            turn = np.abs(np.arctan2((gh[1:] / gh[:-1]).imag, (gh[1:] / gh[:-1]).real))
            rate = np.abs((points[3] / gh).imag * points[0].real)
            if np.sum(turn) < FLAT and np.max(rate) < FLAT:
                flat.add("phase")
    return flat, shallow | flat


def _needs_split(start: NDArray, stop: NDArray, shallow: set[str] | frozenset[str] = frozenset()) -> NDArray[np.bool_]:
    """Intervals (ends: columns of `_with_curve` rows) that could hide a
    crossing or extremum pair, or step too far in phase.

    Row by row: the turns of GH, 1 + GH and the tangent dGH over each
    interval, and at each end the angles theta of the tangent against GH
    and phi against 1 + GH (see `may_hide_pair`).  Constant and shallow
    levels (``shallow``) are not split for."""
    with np.errstate(all="ignore"):
        turns = np.abs(_angle(stop[1:] / start[1:]))  # GH, 1 + GH, tangent
        angles0, angles1 = _angle(start[3] / start[1:3]), _angle(stop[3] / stop[1:3])  # theta, phi
        variation = _tangent_turn(start, stop, turns[2]) + turns[:2]
        pair = may_hide_pair(angles0, angles1, variation)  # of |GH|, of |1 + GH|
        coarse = turns[0] > MAX_PHASE_STEP
        if "GH" not in shallow:
            coarse |= pair[0]
        if "1+GH" not in shallow:
            coarse |= pair[1]
        if "phase" not in shallow:
            coarse |= _may_hide_phase_pair(angles0[0], angles1[0], variation[0])
    w0, w1 = start[0].real, stop[0].real
    resolvable = (w1 - w0) > 1e-12 * w1
    return coarse & resolvable & np.isfinite(start[1]) & np.isfinite(stop[1])


def _tangent_turn(start: NDArray, stop: NDArray, net: NDArray) -> NDArray:
    """How far the tangent dGH turns at least over each interval: its net turn, or,
    when larger, its way through the chord's direction.  (Somewhere inside, the
    tangent is parallel to the chord GH(b) - GH(a): Rolle's theorem on GH's
    component across the chord.  An S-shaped stretch turns its tangent one way
    and back: a net turn of 1.4 deg hid a total of 53 deg, and a minimum-maximum
    pair of |1 + GH| with it.)"""
    chord = _angle(stop[1] - start[1])
    through = _line_gap(_angle(start[3]), chord) + _line_gap(chord, _angle(stop[3]))
    return np.maximum(net, np.where(np.isfinite(through), through, 0.0))


def _line_gap(a: NDArray, b: NDArray) -> NDArray:
    """The angle between two lines of directions a and b (parallel or antiparallel: 0)."""
    d = np.abs(np.remainder(a - b + np.pi, 2 * np.pi) - np.pi)
    return np.minimum(d, np.pi - d)


def _angle(z: NDArray) -> NDArray:
    """np.angle without its Python wrapper (this is a hot path)."""
    return np.arctan2(z.imag, z.real)


def may_hide_pair(angle0: NDArray, angle1: NDArray, variation: NDArray) -> NDArray[np.bool_]:
    """Could a distance |r| have a minimum and a maximum inside an interval?

    d|r|/domega changes sign where the tangent dr is perpendicular to r, i.e.
    where the angle between them (given signed at both ends) crosses +-90
    deg.  With both ends on the same side, two crossings need its size to
    vary by the sum of the ends' distances to 90 deg; it varies by at most
    ``variation``: the turn of the tangent plus the turn of r.  Where |r| is
    stationary at both ends (an arc about the origin, which that bound
    would split without end: all-pass shapes, |GH| of a delay loop tending
    to a constant), the tangent turns with r and the net change of the
    angle is the estimate.
    """
    size0, size1 = np.abs(angle0), np.abs(angle1)
    same_side = (size1 < np.pi / 2) == (size0 < np.pi / 2)
    room = np.abs(np.pi / 2 - size0) + np.abs(np.pi / 2 - size1)
    arc = (np.abs(np.pi / 2 - size0) < STATIONARY) & (np.abs(np.pi / 2 - size1) < STATIONARY)
    variation = np.where(arc, np.abs(np.abs(angle1) - np.abs(angle0)), variation)
    return same_side & (variation > TURN_NOISE) & (PAIR_SAFETY * variation > room)


def _may_hide_phase_pair(theta0: NDArray, theta1: NDArray, variation: NDArray) -> NDArray[np.bool_]:
    """Could the phase of r have a maximum and a minimum inside an interval?

    d(arg r)/domega changes sign where the tangent dr is parallel to r: the
    signed angle theta between them crosses 0 or 180 deg.  Same test as
    `may_hide_pair`, with the distance to the nearer of 0 and 180 deg.
    """
    to_radial0 = np.minimum(np.abs(theta0), np.pi - np.abs(theta0))
    to_radial1 = np.minimum(np.abs(theta1), np.pi - np.abs(theta1))
    same_side = (theta1 > 0) == (theta0 > 0)
    return same_side & (variation > TURN_NOISE) & (PAIR_SAFETY * variation > to_radial0 + to_radial1)


def _searched_range(loop: LoopModel) -> tuple[float, float]:
    """Where a delay loop is searched: the user's grid, from below the delay's first half-turn
    (`FIRST_TURN`) up past its first `LOWEST_HALF_TURNS`, and `DECADES_BEYOND` about its rational part's corners (with none, its
    crossover in closed form: `_power_crossover`), extended to every crossover of |GH| (a delay
    leaves |GH| as it is): margins do not depend on the plot grid (2e-4/(s (1 + s/1e-4))
    exp(-3000 s) crosses over at 1.25e-4 rad/s, below the default grid's 1e-3).  The delay's
    grid bounds the top (`_delay_grid`, with a note); for rational loops the range is found in
    `_initial_grid`."""
    lo, hi = float(loop.omega[0]), float(loop.omega[-1])
    lo = lo if lo > 0 else min(float(loop.omega[1]) * 1e-3, 1e-6)
    corners = loop.corner_frequencies[loop.corner_frequencies > 0]
    if loop.evaluate is None or not loop.delay > 0:  # a table's fit: only its range
        return lo, hi
    lo = min(lo, FIRST_TURN / loop.delay)  # the delay's first half-turns: its lowest phase crossings
    hi = max(hi, LOWEST_HALF_TURNS * math.pi / loop.delay)
    if not corners.size:  # K s^m exp(-tau s): its crossover in closed form
        corners = _power_crossover(loop)
        if not corners.size:
            return lo, hi
    low, high = _extend_to_crossovers(loop, corners.min() * 10.0**-DECADES_BEYOND, corners.max() * 10.0**DECADES_BEYOND)
    return min(lo, low), max(hi, high)


def _power_crossover(loop: LoopModel) -> NDArray[np.float64]:
    """The gain crossover of a loop with no corners, |GH| = |K| omega^m (m the count of
    zeros less poles at the origin, read as the slope of log |GH| at omega = 1):
    |K|^(-1/m); none when m = 0 (|GH| constant) or GH is not finite at 1."""
    with np.errstate(all="ignore"):
        gh, dgh = (x[0] for x in loop.evaluate(np.array([1.0])))
        slope = round(float((dgh / gh).real)) if np.isfinite(gh) and gh != 0 and np.isfinite(dgh) else 0
        crossover = abs(gh) ** (-1.0 / slope) if slope else np.nan
    return np.array([crossover]) if np.isfinite(crossover) and crossover > 0 else np.zeros(0)


def _beyond_note(loop: LoopModel, top: float) -> str:
    """Which margins may lie beyond the top of a delay loop's search."""
    with np.errstate(all="ignore"):
        level = float(np.abs(loop.evaluate(np.array([top]))[0][0]))
    if level >= 1.0:
        return (
            f"|GH| is {level:.3g} there: phase margins, the delay margin and gain margins may lie beyond "
            "(the delay margin is not known)"
        )
    return f"|GH| is {level:.3g} there: gain and stability margins above |GH| = {level:.3g} may lie beyond"


def _delay_points(loop: LoopModel, lo: float, hi: float) -> tuple[int, float]:
    """Points of the linear delay grid over [lo, hi] and its spacing (0, 0 without a delay)."""
    tau = loop.delay
    if loop.rational or not tau > 0 or not math.isfinite(tau):
        return 0, 0.0
    spacing = math.pi / (POINTS_PER_HALF_TURN * tau)
    return int(min(MAX_BUDGET, math.ceil((hi - lo) / spacing) + 1)), spacing


def _initial_grid(
    loop: LoopModel, budget: int, notes: list[str], searched: tuple[float, float] | None
) -> NDArray[np.float64]:
    """Background, clusters around light corners, the delay grid (within half
    the budget), and for delay loops (``searched``: their range) the user's grid;
    never on an undamped corner itself, where GH may be infinite."""
    corners = loop.corner_frequencies
    if loop.rational:
        lo = corners.min() if corners.size else 1.0
        hi = corners.max() if corners.size else 1.0
        lo, hi = _extend_to_crossovers(loop, lo * 10.0**-DECADES_BEYOND, hi * 10.0**DECADES_BEYOND)
    else:
        lo, hi = searched
    lo, hi = max(lo, RANGE[0]), min(hi, RANGE[1])  # corners at the ends of the floating-point range
    if not lo < hi:
        raise EngineError(
            f"the loop's corners lie beyond {RANGE[0]:g}..{RANGE[1]:g} rad/s: no frequency range to search"
        )
    delayed, hi = _delay_grid(loop, lo, hi, DELAY_BUDGET, notes)
    n = max(int(np.ceil((np.log10(hi) - np.log10(lo)) * POINTS_PER_DECADE)), 2)  # hi / lo may overflow
    background = np.exp(np.linspace(math.log(lo), math.log(hi), n))
    background[0], background[-1] = lo, hi
    parts = [background]
    light = loop.dampings < LIGHT_DAMPING
    wn, zeta = corners[light, None], loop.dampings[light, None]
    cluster = wn * (1.0 + np.maximum(zeta, 1e-9) * CLUSTER)
    parts.append(cluster[(zeta > UNDAMPED) | (CLUSTER != 0)])
    parts.append(delayed)
    if not loop.rational:
        parts.append(loop.omega[loop.omega > 0])
    w = np.unique(np.concatenate(parts))
    w = w[(w >= lo) & (w <= hi)]
    undamped = corners[loop.dampings <= UNDAMPED]
    if undamped.size:
        near = np.min(np.abs(w[:, None] / undamped[None, :] - 1.0), axis=1) < 1e-9
        w = w[~near]
    return w


def _delay_grid(loop: LoopModel, lo: float, hi: float, most: int, notes: list[str]) -> tuple[NDArray, float]:
    """`POINTS_PER_HALF_TURN` points per pi/tau from ``lo`` up, at most
    ``most`` of them, and the top of the range they resolve (the search
    stops there: beyond it crossings would alias)."""
    count, spacing = _delay_points(loop, lo, hi)
    if count == 0:
        return np.zeros(0), hi
    if count > most:
        top = lo + (most - 1) * spacing
        if not top > lo * (1 + 1e-9):
            raise EngineError(
                f"the delay ({loop.delay:.6g} s) turns the phase by pi within "
                f"{spacing:.3g} rad/s: no frequency range can be searched"
            )
        notes.append(
            f"the delay ({loop.delay:.6g} s) turns the phase faster than the grid's budget can "
            f"follow: searched up to {top:.6g} rad/s, not up to {hi:.6g}; " + _beyond_note(loop, top)
        )
        count, hi = most, top
    return lo + spacing * np.arange(count), hi


def _extend_to_crossovers(loop: LoopModel, lo: float, hi: float) -> tuple[float, float]:
    """Move each end out by decades while |GH| still moves towards (or across) 1
    beyond it (up to 40 decades; eight at a time, both ends in one evaluation)."""
    steps = 10.0 ** np.arange(DECADES_PER_LOOK + 1)
    for _ in range(40 // DECADES_PER_LOOK):
        level = _log_levels(loop, np.concatenate([hi * steps, lo / steps]))
        up, down = _decades_moving(level[: steps.size]), _decades_moving(level[steps.size :])
        hi, lo = hi * 10.0**up, lo / 10.0**down
        if up < DECADES_PER_LOOK and down < DECADES_PER_LOOK:
            break
    return lo, hi


def _log_levels(loop: LoopModel, omega: NDArray) -> NDArray:
    """log |GH| at ``omega``; NaN where GH is beyond the floating-point range (far below
    the corners of a type-3 loop): there the extension stops."""
    with np.errstate(all="ignore"):
        try:
            return np.log(np.abs(loop.evaluate(omega)[0]))
        except EngineError:
            return np.array(
                [_log_levels(loop, omega[k : k + 1])[0] if omega.size > 1 else np.nan for k in range(omega.size)]
            )


def _decades_moving(level: NDArray) -> int:
    """How many steps in a row log |GH| keeps moving towards (or across) 0."""
    values = level.tolist()  # plain floats: numpy scalars are slow in a Python loop
    for k in range(len(values) - 1):
        f0, f1 = values[k], values[k + 1]
        if not (math.isfinite(f0) and math.isfinite(f1) and (f0 * f1 <= 0 or abs(f1) < abs(f0) - 1e-6)):
            return k
    return len(values) - 1

"""The certificate of the stationary points found by `engine.margins.pole_zero.search`,
with the repair of single misses.

The stationary points of a smooth level alternate between maxima and
minima, and its slope has the sign their order predicts everywhere else:
negative past a maximum, positive past a minimum.  The slopes are read at
check points (between and around the points, at every root's frequency, on
a ladder two points a decade wide from 1e-3 of the smallest root to 1e3
times the largest, and at every near-real eigenvalue, where a close pair
could hide).  A slope within its rounding (``noise``) has no sign: its
check point is skipped for that level (a level flat to rounding, such as
|S| = 1 to 1e-12 far below a type-1 loop's crossover, has no features a
peak or a margin could show).  Where a check point's sign contradicts its neighbour's, an
odd number of stationary points was missed between them (far above the
crossover, where |GH| falls like a high power, the sums of fractions cancel
beyond what their eigenvalues resolve): one is bracketed there and refined,
and the check is made again, at most `REPAIR_ROUNDS` times.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from engine.margins.pole_zero.levels import LoopLevels
from engine.numerics.bracketing import Noise, bracketed_roots

# omega -> (rows of each level's slope, rows of their derivatives)
Slopes = Callable[[NDArray], tuple[NDArray, NDArray]]
# (omega -> rows of the levels' values, each level's limits at 0 and at infinity)
Ends = tuple[Callable[[NDArray], NDArray], list[tuple[float, float]]]

CLEARANCE = 1e-6  # relative distance from a stationary point within which a slope's sign is rounding
REPAIR_ROUNDS = 4
DUPLICATE = 1e-9  # relative distance at which two stationary points are one
LIMIT_SLACK = 1e-12  # a level this close (relative) to its limit is at it


def certified(
    loop: LoopLevels,
    points: list[NDArray],
    maxima: list[NDArray],
    near: NDArray,
    slopes: Slopes | None = None,
    ends: Ends | None = None,
    noise: Callable[[NDArray], NDArray] | None = None,
    constant: list[bool] | None = None,
) -> tuple[list[NDArray], list[NDArray]] | None:
    """Per level (row k of ``slopes``, by default of `LoopLevels.slopes`), its
    stationary points and which are maxima, checked and repaired (module
    docstring), and with ``ends`` (the levels' values and their limits at 0 and
    infinity) checked against the limits: a level rises to a maximum and falls
    from it, so the first maximum is not below the limit at 0, the last not
    below the limit at infinity (minima alike), and a level with none is not
    equal at both ends (unless ``constant`` says it is constant: then it has
    none).  ``noise``: rows of each slope's rounding (by default
    `LoopLevels.slope_noise`).  None when a check still fails."""
    probe = loop.slopes_and_noise if slopes is None and noise is None else None
    slopes, noise = slopes or loop.slopes, noise or loop.slope_noise
    every = np.concatenate(points)
    parts = [loop.probes, near]
    for w in points:
        if w.size:
            parts += [np.sqrt(w[1:] * w[:-1]), w[:1] / 4, w[-1:] * 4]
    probes = np.concatenate(parts)
    if every.size:
        probes = probes[np.min(np.abs(probes[:, None] / every[None, :] - 1.0), axis=1) > CLEARANCE]
    first, rounding = probe(probes) if probe else (slopes(probes)[0], noise(probes))
    first = first[: len(points)]
    signs = np.where(np.abs(first) > rounding[: len(points)], np.sign(first), np.where(np.isnan(first), np.nan, 0.0))
    out_points, out_maxima = [], []
    for row, (w, top) in enumerate(zip(points, maxima)):
        for _ in range(REPAIR_ROUNDS + 1):
            missed = _contradictions(w, top, probes, signs[row])
            if missed is None:
                break
            repaired = _repaired(slopes, row, w, top, *missed, noise=lambda omega: noise(omega)[row])
            if repaired is None:
                return None
            w, top = repaired
        else:
            return None
        out_points.append(w)
        out_maxima.append(top)
    if ends is not None and not _all_reach(out_points, out_maxima, ends, constant or [False] * len(points)):
        return None
    return out_points, out_maxima


def _all_reach(points: list[NDArray], maxima: list[NDArray], ends: Ends, constant: list[bool]) -> bool:
    """`_reaches` for every level that is not constant (its values read in one evaluation)."""
    every = np.concatenate(points)
    values = ends[0](every) if every.size else np.zeros((len(points), 0))
    start = 0
    for row, (w, top) in enumerate(zip(points, maxima)):
        own, start = values[row, start : start + w.size], start + w.size
        if not constant[row] and not _reaches(own, top, ends[1][row]):
            return False
    return True


def _reaches(values: NDArray, maxima: NDArray, limits: tuple[float, float]) -> bool:
    """Are a level's values at its stationary points (maxima flagged) consistent with
    its limits at 0 and infinity?  (A missed extremum placed far from every check
    point shows here: a level that cannot rise to its first maximum from its limit.)"""

    def near(a: float, b: float) -> bool:
        return math.isfinite(a) and math.isfinite(b) and abs(a - b) <= LIMIT_SLACK * max(1.0, abs(a), abs(b))

    low, high = limits
    if values.size == 0:
        return not near(low, high)
    for value, top, limit in ((values[0], maxima[0], low), (values[-1], maxima[-1], high)):
        if not near(value, limit) and (value < limit if top else value > limit):
            return False
    return True


def _contradictions(w: NDArray, maxima: NDArray, probes: NDArray, slope: NDArray) -> tuple[NDArray, NDArray] | None:
    """The intervals (lo, hi) between neighbouring stationary and check points
    whose slope signs contradict each other (check points without a sign
    skipped); None when there are none."""
    after = np.where(maxima, -1.0, 1.0)
    known = slope != 0
    probes, slope = probes[known], slope[known]
    at = np.concatenate([w, probes])
    left = np.concatenate([-after, slope])
    right = np.concatenate([after, slope])
    order = np.argsort(at, kind="stable")
    at, left, right = at[order], left[order], right[order]
    bad = np.flatnonzero(right[:-1] != left[1:])
    if bad.size == 0:
        return None
    stationary = order < w.size
    lo = np.where(stationary[bad], at[bad] * (1 + CLEARANCE), at[bad])
    hi = np.where(stationary[bad + 1], at[bad + 1] * (1 - CLEARANCE), at[bad + 1])
    return lo, hi


def _repaired(
    slopes: Slopes, row: int, w: NDArray, maxima: NDArray, lo: NDArray, hi: NDArray, noise: Noise
) -> tuple[NDArray, NDArray] | None:
    """The stationary points with one more found in each interval; None when an
    interval holds no sign change of the slope or its search does not settle
    (``noise``: the slope's rounding, where its search may stop)."""
    found = _bracketed_roots(slopes, row, lo, hi, noise)
    if found is None:
        return None
    w = np.concatenate([w, found[0]])
    maxima = np.concatenate([maxima, found[1] < 0])
    order = np.argsort(w)
    w, maxima = w[order], maxima[order]
    keep = np.concatenate([[True], np.diff(w) > DUPLICATE * w[1:]])
    return w[keep], maxima[keep]


def _bracketed_roots(
    slopes: Slopes, row: int, lo: NDArray, hi: NDArray, noise: Noise
) -> tuple[NDArray, NDArray] | None:
    """A root of the level's slope in each [lo, hi] (its ends of opposite signs)
    and the second derivative there; None when one does not settle."""

    def fun(w: NDArray, which: NDArray) -> tuple[NDArray, NDArray]:
        first, second = slopes(w)
        return first[row], second[row]

    found = bracketed_roots(fun, lo, hi, noise)
    return None if found is None else (found, slopes(found)[1][row])

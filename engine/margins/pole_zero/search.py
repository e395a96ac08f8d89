"""Margins of a rational loop in pole-zero form, without a detection grid.

On s = j omega, with x = omega**2 and the loop's roots r (zeros sigma = +1,
poles sigma = -1), each level the margins read has a derivative that is a sum
of simple fractions in x with poles at t = -r**2:

    d/domega log|GH|    = omega sum sigma / (x + r**2)
    d/domega arg GH     = -sum sigma r / (x + r**2)
    d/domega log|1+GH|  = omega (sum_c 1/(x + c**2) - sum_p 1/(x + p**2))

(c: the closed-loop poles, the zeros of 1 + GH).  Their zeros, the levels'
stationary points, are eigenvalues found without expanding a polynomial
(`engine.numerics.fraction_sums`; for |1 + GH| also from its residue form,
`engine.margins.pole_zero.levels.distance_stationary`).  The crossings start from the
roots of two small polynomials.  Every start is polished by Newton's method
on the exact pole-zero form with analytic derivatives (maxima of |GH| are
the attenuation margins, minima of |1 + GH| the stability margins); the
stationary points are certified and single misses repaired
(`engine.margins.pole_zero.certificate`), and the crossings counted piece by piece between
them (`engine.margins.pole_zero.crossings`).  Whenever a condition of the method fails
(roots on the imaginary axis, a constant |1 + GH|, |GH| = 1 or GH on the
negative real axis at every frequency, a check, a step limit) the answer is
None and `engine.margins.search` takes the detection grid instead.  Another
constant level (|GH| of an all-pass shape, the phase of K / s**n) simply has
no stationary points (`LoopLevels.constant`).
"""

from __future__ import annotations

import cmath
import math

import numpy as np
from numpy.typing import NDArray

from engine.loop.pole_zero import ZpkEvaluator
from engine.margins.pole_zero.certificate import DUPLICATE, Slopes, certified
from engine.margins.pole_zero.crossings import crossing_candidates, crossings_of
from engine.margins.pole_zero.levels import LoopLevels
from engine.numerics.bracketing import EPS, NOISE_STEP

REAL = 1e-7  # |Im x| / |x| below which an eigenvalue is a real stationary point
NEAR_REAL = 1e-2  # ... below which a close real pair could hide near it (a check point there)
NEWTON_STEPS = 12
FLAT = 1e-9  # a constant log|GH| within this of 0, or phase within this of 180 deg, is degenerate


def fast_margins(form: ZpkEvaluator) -> dict[str, NDArray[np.float64]] | None:
    """Frequencies of the gain crossings of the negative real axis ("G"), the
    gain crossovers ("P"), the minima of |1 + GH| ("S") and the maxima of |GH|
    ("A"); None when the method does not apply or a check fails."""
    loop = LoopLevels.of(form)
    if loop is None:
        return None
    with np.errstate(all="ignore"):
        starts = _starts(loop)
        if starts is None:
            return None  # a degenerate level: the detection grid names it
        w, kind, near = starts
        found = distinct(*newton(loop.slopes, w, kind), kinds=5)
        if found is None:
            return None
        points, maxima = found
        constant = [name in loop.constant for name in ("GH", "phase")] + [False]
        checked = certified(loop, points[:3], maxima[:3], near, ends=(loop.values, loop.all_limits), constant=constant)
        if checked is None:
            return None
        points[:3], maxima[:3] = checked
        crossings = crossings_of(loop, points)
    if crossings is None:
        return None
    loop.certified_distance = (points[2], maxima[2])  # the closed-loop peaks of |S| read them
    return {"G": crossings[1], "P": crossings[0], "S": points[2][~maxima[2]], "A": points[0][maxima[0]]}


def _starts(loop: LoopLevels) -> tuple[NDArray, NDArray, NDArray] | None:
    """Newton's starting points and their kinds (rows of `LoopLevels.slopes`:
    0-2 the stationary points of log|GH|, arg GH and log|1 + GH|, 3 gain
    crossovers, 4 phase crossings), and the frequencies of the near-real
    eigenvalues (check points)."""
    if degenerate(loop):
        return None
    no_points = np.zeros(0, dtype=complex)
    eigenvalues = [
        no_points if weights is None else loop.fractions.zeros_of(weights) for weights in loop.slope_weights.values()
    ] + [loop.distance_starts]
    if any(x is None for x in eigenvalues):
        return None
    x = np.concatenate(eigenvalues)
    kind = np.repeat(np.arange(3), [e.size for e in eigenvalues])
    real, near = real_eigenvalues(x)
    gains, phases = crossing_candidates(loop)
    w = np.concatenate([np.sqrt(x.real[real]), gains, phases])
    kind = np.concatenate([kind[real], np.full(gains.size, 3), np.full(phases.size, 4)])
    return w, kind, near


def degenerate(loop: LoopLevels) -> bool:
    """Is a constant level one whose crossings are not isolated (|GH| = 1 everywhere,
    or GH on the negative real axis everywhere)?  The detection grid names it."""
    if not loop.constant:
        return False
    gh = loop.sample
    return ("GH" in loop.constant and abs(math.log(abs(gh))) <= FLAT) or (
        "phase" in loop.constant and abs(math.remainder(cmath.phase(gh) - math.pi, 2 * math.pi)) <= FLAT
    )


def real_eigenvalues(x: NDArray) -> tuple[NDArray, NDArray]:
    """Which eigenvalues x = omega^2 are real and positive (to `REAL`: Newton's
    starts), and the frequencies of those only near it (to `NEAR_REAL`: check points)."""
    positive = x.real > 0
    real = positive & (np.abs(x.imag) <= REAL * np.abs(x))
    return real, np.sqrt(x.real[positive & ~real & (np.abs(x.imag) <= NEAR_REAL * np.abs(x))])


def newton(slopes: Slopes, w: NDArray, kind: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Newton's method on each point's own row of ``slopes`` (first / second): the points
    converged, their kinds and second derivatives.  A point is done when its
    step is within 4 ulp, or when its steps, already below `NOISE_STEP`,
    stop shrinking: the rounding noise is reached (a flat extremum is
    determined no better).  A point that does not converge (a spurious
    eigenvalue where the level is flat to rounding) is dropped; the
    certificate judges what is left."""
    done, previous, second = np.zeros(w.size, dtype=bool), np.full(w.size, np.inf), np.zeros(w.size)
    columns = np.arange(w.size)
    for _ in range(NEWTON_STEPS):
        first, bend = slopes(w)
        first, bend = first[kind, columns], bend[kind, columns]
        second = np.where(done, second, bend)
        step = np.where(done, 0.0, first / bend)
        size = np.abs(step)
        finished = (size <= 4 * EPS * w) | ((size <= NOISE_STEP * w) & (size >= 0.5 * previous))
        moved = w - step
        lost = ~(np.isfinite(moved) & (moved > 0))
        w = np.where(lost, w, moved)
        done |= finished & ~lost
        previous = np.where(lost, np.inf, size)
        if (done | lost).all():
            break
    return w[done], kind[done], second[done]


def distinct(w: NDArray, kind: NDArray, second: NDArray, kinds: int) -> tuple[list[NDArray], list[NDArray]] | None:
    """Per kind, the points sorted, two that met merged, and which are maxima;
    None when one is degenerate (a zero second derivative: not a simple root)."""
    if (second == 0).any():
        return None
    order = np.lexsort((w, kind))
    w, kind, second = w[order], kind[order], second[order]
    keep = np.ones(w.size, dtype=bool)
    keep[1:] = (kind[1:] != kind[:-1]) | (np.diff(w) > DUPLICATE * w[1:])
    w, kind, second = w[keep], kind[keep], second[keep]
    bounds = np.searchsorted(kind, np.arange(kinds + 1))
    return (
        [w[bounds[k] : bounds[k + 1]] for k in range(kinds)],
        [second[bounds[k] : bounds[k + 1]] < 0 for k in range(kinds)],
    )

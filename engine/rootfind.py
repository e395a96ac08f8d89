"""Vectorized bracketed refinement of many crossings or extrema at once: each
iteration evaluates the function at every open bracket in one call, so no
Python loop runs per frequency.

Every evaluation gives a level h and its slope h' (margins have both from
GH and dGH/domega), so the steps are of high order:
* crossings (roots of h): the cubic Hermite interpolant of the inverse
  function, which is of fourth order (Newton's step when it leaves the bracket);
* extrema (roots of h'): the stationary point of the cubic that matches h and
  h' at both ends (the cubic line-search step), which converges about
  quadratically; once the bracket is too narrow for the difference of h to
  carry information, the secant of h'.
Each step also evaluates a guard point a tenth of the step beyond the
estimate: when the estimate converges from one side (a stale bracket end)
the guard lands past the root and the bracket shrinks to the two points, so
the cubic keeps its order.  A step that is not finite or leaves the bracket
is replaced by a trisection (the two points at thirds), and so is every
step after a run of steps that failed to halve the bracket, so the worst
case is trisection's.  A bracket is done when its next step would move its
better end by at most 4 ulp (the correction is the error estimate of a
converging Newton or cubic step) or its width reaches 4 ulp."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

EPS = np.finfo(float).eps
CUBIC_NARROWEST = 1e-7  # relative bracket width below which the cubic's difference of h is noise
GUARD = 0.1  # a second point this fraction of the step beyond the estimate, to bracket the root closely
STALL_STEPS = 3  # steps without halving the bracket before trisection takes over

LevelFunction = Callable[[NDArray, NDArray], tuple[NDArray, NDArray]]


def refine(fun: LevelFunction, a: NDArray, b: NDArray, ha: NDArray, hb: NDArray, da: NDArray, db: NDArray,
           stationary: bool, max_iter: int = 200) -> NDArray[np.float64]:
    """Roots of h (``stationary`` False) or of h' (True) in brackets [a, b]
    (a < b) over which that function changes sign, given h and h' at both ends.

    ``fun(points, which)`` gives (h, h') at ``points`` for the brackets
    numbered ``which`` (one call can serve different level functions).
    """
    row = 2 if stationary else 1  # of omega, h, h': the one whose sign changes across the bracket
    step = _stationary_step if stationary else _crossing_step
    lo, hi = np.array([a, ha, da], dtype=float), np.array([b, hb, db], dtype=float)
    root = np.where(lo[row] == 0, lo[0], np.where(hi[row] == 0, hi[0], np.nan))
    idx = np.flatnonzero(np.isnan(root))
    lo, hi = lo[:, idx], hi[:, idx]
    reference_width, stalled = hi[0] - lo[0], np.zeros(idx.size, dtype=int)
    with np.errstate(all="ignore"):
        for _ in range(max_iter):
            if idx.size == 0:
                break
            x = step(lo, hi)
            best = np.where(np.abs(lo[row]) <= np.abs(hi[row]), lo[0], hi[0])
            tolerance = 4 * EPS * np.abs(best)
            settled = np.abs(x - best) <= tolerance  # the next correction is below 4 ulp
            done = settled | (hi[0] - lo[0] <= tolerance)
            if done.any():
                root[idx[done]] = np.where(settled, x, best)[done]
                going = ~done
                idx, lo, hi, x, best = idx[going], lo[:, going], hi[:, going], x[going], best[going]
                reference_width, stalled = reference_width[going], stalled[going]
                if idx.size == 0:
                    break
            bisect = ~((x > lo[0]) & (x < hi[0])) | (stalled >= STALL_STEPS)  # also where x is not finite
            guard = np.clip(x + GUARD * (x - best), lo[0], hi[0])
            third = (hi[0] - lo[0]) / 3.0
            p = np.where(bisect, lo[0] + third, np.minimum(x, guard))
            q = np.where(bisect, hi[0] - third, np.maximum(x, guard))
            h, d = fun(np.concatenate([p, q]), np.concatenate([idx, idx]))
            n = idx.size
            at_p, at_q = np.array([p, h[:n], d[:n]]), np.array([q, h[n:], d[n:]])
            # the first sign change from the left; an exact zero counts as a change
            in_first = np.sign(at_p[row]) != np.sign(lo[row])  # [lo, p]
            in_middle = ~in_first & (np.sign(at_q[row]) != np.sign(at_p[row]))  # [p, q], else [q, hi]
            lo, hi = (np.where(in_first, lo, np.where(in_middle, at_p, at_q)),
                      np.where(in_first, at_p, np.where(in_middle, at_q, hi)))
            width = hi[0] - lo[0]
            halved = width <= 0.5 * reference_width
            reference_width = np.where(halved, width, reference_width)
            stalled = np.where(halved | bisect, 0, stalled + 1)
    if idx.size:
        root[idx] = 0.5 * (lo[0] + hi[0])
    return root


def _crossing_step(lo: NDArray, hi: NDArray) -> NDArray:
    """The root of h from the cubic Hermite interpolant of the inverse
    function omega(h) (rows of lo, hi: omega, h, h'; fourth order while h is monotone),
    or Newton's step from the end with the smaller |h| when that falls outside
    the bracket."""
    rise = hi[1] - lo[1]
    u = -lo[1] / rise
    slope_lo, slope_hi = rise / lo[2], rise / hi[2]  # d omega / du at the ends
    u2, u3 = u * u, u * u * u
    inverse = ((2 * u3 - 3 * u2 + 1) * lo[0] + (u3 - 2 * u2 + u) * slope_lo
               + (3 * u2 - 2 * u3) * hi[0] + (u3 - u2) * slope_hi)
    newton = np.where(np.abs(lo[1]) < np.abs(hi[1]), lo[0] - lo[1] / lo[2], hi[0] - hi[1] / hi[2])
    return np.where((inverse > lo[0]) & (inverse < hi[0]), inverse, newton)


def _stationary_step(lo: NDArray, hi: NDArray) -> NDArray:
    """The stationary point in [lo, hi] of the cubic Hermite interpolant of h.

    In t = (x - lo)/(hi - lo) the cubic's slope is A t^2 + B t + C with
    C = alpha, A + B + C = beta (alpha, beta: the end slopes times the
    width), of opposite signs, so exactly one root lies in (0, 1).  When the
    bracket is narrow the secant of h' (A = 0) is used instead.
    """
    width = hi[0] - lo[0]
    alpha, beta, rise = lo[2] * width, hi[2] * width, hi[1] - lo[1]
    A = 3.0 * (alpha + beta - 2.0 * rise)
    B = 2.0 * (3.0 * rise - 2.0 * alpha - beta)
    q = -0.5 * (B + np.copysign(np.sqrt(np.maximum(B * B - 4.0 * A * alpha, 0.0)), B))
    t1, t2 = q / A, alpha / q
    t = np.where((t1 > 0) & (t1 < 1), t1, t2)
    narrow = width <= CUBIC_NARROWEST * np.abs(hi[0])
    return lo[0] + width * np.where(narrow | ~np.isfinite(t), alpha / (alpha - beta), t)


def sign_changes(f: NDArray, rising_only: bool = False, falling_only: bool = False) -> NDArray[np.intp]:
    """Indices i where f[i] and f[i+1] have strictly opposite signs."""
    s = np.sign(f)
    change = s[:-1] * s[1:] < 0
    if rising_only:
        change &= s[:-1] < 0
    if falling_only:
        change &= s[:-1] > 0
    return np.flatnonzero(change)

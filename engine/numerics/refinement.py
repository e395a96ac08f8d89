"""Vectorized bracketed refinement of many crossings or extrema at once: each
iteration evaluates the function at every open bracket in one call, so no
Python loop runs per frequency.

Every evaluation gives a level h and its slope h' (margins have both from
GH and dGH/domega), so the steps are of high order:
* crossings (roots of h): the cubic Hermite interpolant of the inverse
  function, which is of fourth order (Newton's step when it leaves the
  bracket or is not monotone);
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

from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from engine.numerics.iteration import Status, Work, iterate

EPS = np.finfo(float).eps
CUBIC_NARROWEST = 1e-7  # relative bracket width below which the cubic's difference of h is noise
GUARD = 0.1  # a second point this fraction of the step beyond the estimate, to bracket the root closely
STALL_STEPS = 3  # steps without halving the bracket before trisection takes over

LevelFunction = Callable[[NDArray, NDArray], tuple[NDArray, NDArray]]


class Roots(NamedTuple):
    """What `refine` found: the root in each bracket, and for each bracket
    watched for hidden crossings the two it revealed (NaN where none)."""

    at: NDArray[np.float64]
    hidden: NDArray[np.float64]  # (brackets, 2): left and right crossing
    bounded: int = 0  # brackets the bound on rounds stopped (their middles stand): Status.ROUNDS
    stopped: NDArray[np.bool_] | None = None  # which: the roots, then the hidden crossings (two a bracket)


def refine(
    fun: LevelFunction,
    a: NDArray,
    b: NDArray,
    ha: NDArray,
    hb: NDArray,
    da: NDArray,
    db: NDArray,
    stationary: bool | NDArray[np.bool_],
    hiding: NDArray[np.bool_] | None = None,
    max_iter: int = 200,
) -> Roots:
    """Roots of h (where ``stationary`` is False) or of h' (True; a bool or
    one per bracket) in brackets [a, b] (a < b) over which that function
    changes sign, given h and h' at both ends.

    ``fun(points, which)`` gives (h, h') at ``points`` for the brackets
    numbered ``which`` (one call can serve different level functions).

    Brackets of extrema flagged ``hiding`` have h of one sign at both ends:
    the extremum inside may lie across h = 0, with a crossing of h on either
    side.  As soon as a step lands across, the two crossings get brackets of
    their own (between that point and its nearest neighbours on the ends'
    side) and are refined in the same loop, as bracket ``which`` of their
    extremum.
    """
    n = np.size(a)
    stationary = np.broadcast_to(np.asarray(stationary, dtype=bool), (n,))
    # rows of a bracket end: omega, h, h', and the target whose sign changes (h' or h)
    lo = np.array([a, ha, da, np.where(stationary, da, ha)], dtype=float).reshape(4, n)
    hi = np.array([b, hb, db, np.where(stationary, db, hb)], dtype=float).reshape(4, n)
    watch = (
        np.zeros(n, dtype=bool)
        if hiding is None
        else (np.asarray(hiding, dtype=bool) & stationary & (np.sign(lo[1]) == np.sign(hi[1])) & (lo[1] != 0))
    )
    out = np.full(3 * n, np.nan)  # the roots, then two hidden crossings per bracket
    out[:n] = np.where(lo[3] == 0, lo[0], np.where(hi[3] == 0, hi[0], np.nan))
    start = np.flatnonzero(np.isnan(out[:n]))
    start = start[np.argsort(~stationary[start], kind="stable")]  # extrema first: each step on a slice
    work = {
        "slot": start,
        "which": start,
        "lo": lo[:, start],
        "hi": hi[:, start],
        "stationary": stationary[start],
        "watch": watch[start],
        "side": np.sign(lo[1, start]),
        "reference_width": hi[0, start] - lo[0, start],
        "stalled": np.zeros(start.size, dtype=int),
    }

    bounded = np.zeros(3 * n, dtype=bool)  # the slots the bound on rounds stopped

    def finish(work: Work, which: NDArray[np.bool_], status: NDArray[np.int8]) -> None:
        # settled: the estimate or the better end; the rounds ran out: the bracket's middle
        middle = 0.5 * (work["lo"][0][which] + work["hi"][0][which])
        slots, rounds = work["slot"][which], status == Status.ROUNDS
        out[slots] = np.where(rounds, middle, work["root"][which])
        bounded[slots[rounds]] = True

    def advance(work: Work) -> Work:
        p, q, bisect = _next_points(work, work["x"], work["best"])
        points, m = np.concatenate([p, q]), p.size
        h, d = fun(points, np.concatenate([work["which"], work["which"]]))
        kind = work["stationary"]
        # rows omega, h, h', target for p and q side by side: one array, viewed as two
        rows = np.stack([points, h, d, np.where(np.concatenate([kind, kind]), d, h)])
        at_p, at_q = rows[:, :m], rows[:, m:]
        watch, revealed = _revealed(work, at_p, at_q, n)
        work = _narrowed(work | {"watch": watch}, at_p, at_q, bisect)
        if revealed is not None:
            work = {key: np.concatenate([work[key], revealed[key]], axis=-1) for key in revealed}
        return work

    with np.errstate(all="ignore"):
        iterate(work, _stopped, advance, finish, max_iter)
    return Roots(out[:n], out[n:].reshape(n, 2), int(np.count_nonzero(bounded)), bounded)


class Job(NamedTuple):
    """One caller's brackets and level function for `refine_together` (`refine`'s arguments)."""

    fun: LevelFunction
    a: NDArray
    b: NDArray
    ha: NDArray
    hb: NDArray
    da: NDArray
    db: NDArray
    stationary: bool | NDArray[np.bool_]
    hiding: NDArray[np.bool_] | None = None


def refine_together(jobs: Sequence[Job], max_iter: int = 200) -> list[Roots]:
    """Several callers' brackets refined in one `refine` (one vectorized step a round for all of them,
    each job's function evaluated on its own brackets' points): each job's `Roots` are what `refine`
    gives it alone, every bracket being stepped on its own."""
    sizes = [int(np.size(job.a)) for job in jobs]
    starts = np.cumsum([0] + sizes)

    def fun(points: NDArray, which: NDArray) -> tuple[NDArray, NDArray]:
        h, d = np.empty(points.size), np.empty(points.size)
        for job, lo, hi in zip(jobs, starts[:-1], starts[1:]):
            mine = (which >= lo) & (which < hi)
            if mine.any():
                h[mine], d[mine] = job.fun(points[mine], which[mine] - lo)
        return h, d

    def joined(field: str, dtype: type) -> NDArray:
        parts = [
            np.zeros(size, dtype=bool) if getattr(job, field) is None else getattr(job, field)
            for job, size in zip(jobs, sizes)
        ]
        return np.concatenate([np.broadcast_to(np.asarray(p, dtype=dtype), (size,)) for p, size in zip(parts, sizes)])

    args = [joined(field, float) for field in ("a", "b", "ha", "hb", "da", "db")]
    found = refine(fun, *args, joined("stationary", bool), joined("hiding", bool), max_iter)
    n, out = starts[-1], []
    for lo, hi in zip(starts[:-1], starts[1:]):
        stopped = np.concatenate([found.stopped[lo:hi], found.stopped[n + 2 * lo : n + 2 * hi]])
        out.append(Roots(found.at[lo:hi], found.hidden[lo:hi], int(np.count_nonzero(stopped)), stopped))
    return out


def _stopped(work: Work) -> NDArray[np.int8]:
    """Each bracket's next estimate, its better end and its root if done (`_estimates`), kept in
    the work; CONVERGED where it is done."""
    work["x"], work["best"], done, work["root"] = _estimates(work)
    return np.where(done, Status.CONVERGED, Status.RUNNING).astype(np.int8)


def _estimates(state: dict) -> tuple[NDArray, NDArray, NDArray[np.bool_], NDArray]:
    """Each bracket's next estimate, its better end, whether it is done, and
    its root if so (the estimate where it settled, else the better end)."""
    lo, hi, k = state["lo"], state["hi"], np.count_nonzero(state["stationary"])
    if k == lo.shape[1]:
        x = _stationary_step(lo, hi)
    elif k == 0:
        x = _crossing_step(lo, hi)
    else:
        x = np.concatenate([_stationary_step(lo[:, :k], hi[:, :k]), _crossing_step(lo[:, k:], hi[:, k:])])
    best = np.where(np.abs(lo[3]) <= np.abs(hi[3]), lo[0], hi[0])
    tolerance = 4 * EPS * np.abs(best)
    settled = np.abs(x - best) <= tolerance  # the next correction is below 4 ulp
    done = settled | (hi[0] - lo[0] <= tolerance)
    return x, best, done, np.where(settled, x, best)


def _next_points(state: dict, x: NDArray, best: NDArray) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
    """The two points to evaluate in each bracket: the estimate and its guard,
    or the thirds where the estimate is unusable or progress stalled."""
    lo, hi = state["lo"][0], state["hi"][0]
    bisect = ~((x > lo) & (x < hi)) | (state["stalled"] >= STALL_STEPS)  # also where x is not finite
    guard = np.minimum(np.maximum(x + GUARD * (x - best), lo), hi)
    third = (hi - lo) / 3.0
    return (
        np.where(bisect, lo + third, np.minimum(x, guard)),
        np.where(bisect, hi - third, np.maximum(x, guard)),
        bisect,
    )


def _narrowed(state: dict, at_p: NDArray, at_q: NDArray, bisect: NDArray[np.bool_]) -> dict:
    """Each bracket cut to the first of [lo, p], [p, q], [q, hi] over which
    its target changes sign (an exact zero counts as a change)."""
    lo, hi = state["lo"], state["hi"]
    p_sign = np.sign(at_p[3])
    in_first = p_sign != np.sign(lo[3])
    in_middle = ~in_first & (np.sign(at_q[3]) != p_sign)
    lo, hi = (
        np.where(in_first, lo, np.where(in_middle, at_p, at_q)),
        np.where(in_first, at_p, np.where(in_middle, at_q, hi)),
    )
    width = hi[0] - lo[0]
    halved = width <= 0.5 * state["reference_width"]
    return state | {
        "lo": lo,
        "hi": hi,
        "reference_width": np.where(halved, width, state["reference_width"]),
        "stalled": np.where(halved | bisect, 0, state["stalled"] + 1),
    }


def _revealed(state: dict, at_p: NDArray, at_q: NDArray, n: int) -> tuple[NDArray[np.bool_], dict | None]:
    """Which extrema still watch, and brackets for the two crossings of h
    that a watched extremum's new points reveal (p or q across h = 0 from
    the ends' side; None when nothing was revealed)."""
    watch, side = state["watch"], state["side"]
    if not np.count_nonzero(watch):
        return watch, None
    p_across = watch & (np.sign(at_p[1]) != side)
    q_across = watch & (np.sign(at_q[1]) != side)
    found = p_across | q_across
    if not np.count_nonzero(found):
        return watch, None
    lo, hi = state["lo"][:, found], state["hi"][:, found]
    at_p, at_q, p_across, q_across = at_p[:, found], at_q[:, found], p_across[found], q_across[found]
    # left crossing: [lo, p] when p is across, else [p, q]; right: [q, hi] when q is across, else [p, q]
    left = (np.where(p_across, lo, at_p), np.where(p_across, at_p, at_q))
    right = (np.where(q_across, at_q, at_p), np.where(q_across, hi, at_q))
    slot = n + 2 * state["slot"][found]
    brackets = [np.concatenate(pair, axis=-1) for pair in zip(left, right)]
    for end in brackets:
        end[3] = end[1]  # crossings: the target is h
    size = 2 * slot.size
    return watch & ~found, {
        "slot": np.concatenate([slot, slot + 1]),
        "which": np.tile(state["which"][found], 2),
        "lo": brackets[0],
        "hi": brackets[1],
        "stationary": np.zeros(size, dtype=bool),
        "watch": np.zeros(size, dtype=bool),
        "side": np.zeros(size),
        "reference_width": brackets[1][0] - brackets[0][0],
        "stalled": np.zeros(size, dtype=int),
    }


def _crossing_step(lo: NDArray, hi: NDArray) -> NDArray:
    """The root of h from the cubic Hermite interpolant of the inverse
    function omega(h) (rows of lo, hi: omega, h, h'; fourth order while h is
    monotone), where that cubic is monotone by the Fritsch-Carlson test (end
    slopes over the secant slope alpha, beta > 0 with alpha^2 + beta^2 <= 9)
    and its root lies in the bracket; otherwise Newton's step from the end
    with the smaller |h| (the ends' slopes then differ too much for the
    cubic: one end is far from the root)."""
    width, rise = hi[0] - lo[0], hi[1] - lo[1]
    u = -lo[1] / rise
    slope_lo, slope_hi = rise / lo[2], rise / hi[2]  # d omega / du at the ends
    alpha, beta = slope_lo / width, slope_hi / width
    u2 = u * u
    u3 = u2 * u
    twice_u3, thrice_u2 = 2 * u3, 3 * u2  # each once (the Hermite basis uses them twice)
    inverse = (
        (twice_u3 - thrice_u2 + 1) * lo[0]
        + (u3 - 2 * u2 + u) * slope_lo
        + (thrice_u2 - twice_u3) * hi[0]
        + (u3 - u2) * slope_hi
    )
    newton = np.where(np.abs(lo[1]) < np.abs(hi[1]), lo[0] - lo[1] / lo[2], hi[0] - hi[1] / hi[2])
    usable = (inverse > lo[0]) & (inverse < hi[0]) & (alpha > 0) & (beta > 0) & (alpha * alpha + beta * beta <= 9.0)
    return np.where(usable, inverse, newton)


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

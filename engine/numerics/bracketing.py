"""Roots of many functions of frequency at once, each in its own bracket.

Used where the grid-free margin search must find a root it has no good start
for (`engine.margins.pole_zero.crossings`, `engine.margins.pole_zero.certificate`): h(lo) and h(hi) have
opposite signs, h is given with its derivative.  Steps are taken in
u = log omega (levels of a loop are close to linear in log omega far from its
corners): Newton's step when it stays inside the bracket, else an Illinois
secant step (regula falsi with the stale end's value halved), which keeps
superlinear convergence where Newton overshoots, and a bisection whenever
neither the bracket nor the steps have halved in three steps (Newton crawls
along a power law far from its root, the secant along values of very
different sizes): it never leaves the bracket.  A root is done when its step is
within 4 ulp, when its steps, already below `NOISE_STEP`, stop shrinking
(the rounding noise of a flat root is reached), when Newton's steps (taken or
not: in the noise they leave the bracket) stop shrinking at a value within
the function's own rounding bound (``noise``, when given: a
slope flat to rounding, |T| = 1 to 1e-10 far below a crossover, whose root
double precision places to a few 1e-6 only; bisecting its noise down to 4
ulp took some 30 steps), or when its bracket is 4 ulp wide; all are iterated
together, vectorized.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from engine.numerics.iteration import Status, Work, iterate

MAX_STEPS = 200
NOISE_STEP = 1e-9  # relative step below which steps that stop shrinking are rounding noise
STALL_STEPS = 3  # steps in which a bracket must halve, else it is bisected
EPS = np.finfo(float).eps

# (omega, which) -> (h, dh/domega): point k belongs to root which[k]'s function
Function = Callable[[NDArray, NDArray], tuple[NDArray, NDArray]]
# omega -> the rounding bound of h there (below it h's sign is not known)
Noise = Callable[[NDArray], NDArray]


def bracketed_roots(fun: Function, lo: NDArray, hi: NDArray, noise: Noise | None = None) -> NDArray | None:
    """A root of h in each [lo, hi] (0 < lo < hi, h of opposite signs at the ends);
    None when one does not settle within `MAX_STEPS` (`engine.numerics.iteration`'s
    ROUNDS).  ``noise``: h's rounding bound (module docstring)."""
    if lo.size == 0:
        return np.zeros(0)
    which = np.arange(lo.size)
    a, b = np.log(lo), np.log(hi)
    fa, fb = fun(lo, which)[0], fun(hi, which)[0]
    x = np.where(fa == 0, a, np.where(fb == 0, b, _secant(a, b, fa, fb)))
    inf = np.full(lo.size, np.inf)
    work = {"which": which, "a": a, "b": b, "fa": fa, "fb": fb, "x": x, "finished": (fa == 0) | (fb == 0)}
    work |= {"previous": inf, "before": inf, "proposed_before": inf, "widths": np.tile(np.abs(b - a), (STALL_STEPS, 1))}
    out = np.full(lo.size, np.nan)

    def finish(work: Work, which: NDArray[np.bool_], status: NDArray[np.int8]) -> None:
        out[work["which"][which]] = np.where(status == Status.CONVERGED, work["x"][which], np.nan)

    with np.errstate(all="ignore"):
        outcome = iterate(work, _stopped, lambda work: _advanced(work, fun, noise), finish, MAX_STEPS)
    return np.exp(out) if outcome.bounded == 0 else None


def _stopped(work: Work) -> NDArray[np.int8]:
    return np.where(work["finished"], Status.CONVERGED, Status.RUNNING).astype(np.int8)


def _advanced(work: Work, fun: Function, noise: Noise | None) -> Work:
    """One step of every root still open (module docstring)."""
    a, b, fa, fb, x = work["a"], work["b"], work["fa"], work["fb"], work["x"]
    previous, before = work["previous"], work["before"]
    w = np.exp(x)
    h, dh = fun(w, work["which"])
    low_side = np.sign(h) == np.sign(fa)
    # Illinois: the end that stays has its value halved, so the secant moves it next time
    fb = np.where(low_side, fb * 0.5, fb)
    fa = np.where(low_side, fa, fa * 0.5)
    a, fa = np.where(low_side, x, a), np.where(low_side, h, fa)
    b, fb = np.where(low_side, b, x), np.where(low_side, fb, h)
    newton = x - h / (dh * w)
    inside = (newton > np.minimum(a, b)) & (newton < np.maximum(a, b)) & np.isfinite(newton)
    # a bracket not halved in the last `STALL_STEPS` steps is bisected (Newton crawls along a
    # power law far from its root, the secant along values of very different sizes)
    width = np.abs(b - a)
    stalled = (width > 0.5 * work["widths"][0]) & ~(previous < 0.5 * before)  # steps not shrinking either
    widths = np.concatenate([work["widths"][1:], width[None]])
    tiny = 4 * EPS * np.maximum(1.0, np.abs(x))
    proposed = np.abs(newton - x)  # Newton's step, taken or not (in the noise it leaves the bracket)
    # within 4 ulp the root is reached, even where the step rounds onto the bracket's end
    # (taken as outside, it fell to a secant step 2 % of the bracket away)
    reached = proposed <= tiny
    inside = (inside & ~stalled) | reached
    moved = np.where(inside, newton, np.where(stalled, 0.5 * (a + b), _secant(a, b, fa, fb)))
    size = np.abs(moved - x)
    crawling = (size >= 0.5 * previous) & inside
    settled = reached | (size <= tiny) | (crawling & (size <= NOISE_STEP))
    stuck = (proposed >= 0.5 * work["proposed_before"]) & ~settled
    if noise is not None and stuck.any():  # the bound costs an evaluation: only where it can decide
        settled |= stuck & (np.abs(h) <= noise(w))
    finished = settled | (h == 0) | (np.abs(b - a) <= tiny)
    return work | {
        "a": a,
        "b": b,
        "fa": fa,
        "fb": fb,
        "x": np.where(h == 0, x, moved),
        "finished": finished,
        "previous": np.where(inside, size, np.inf),
        "before": previous,
        "proposed_before": np.where(np.isfinite(proposed), proposed, np.inf),
        "widths": widths,
    }


def _secant(a: NDArray, b: NDArray, fa: NDArray, fb: NDArray) -> NDArray:
    """The secant's zero between (a, fa) and (b, fb), kept off the ends (a
    bisection where the values do not allow one; a secant that creeps along the
    bracket is cut short by the stall test)."""
    with np.errstate(all="ignore"):
        t = np.clip(fa / (fa - fb), 0.02, 0.98)
    return a + np.where(np.isfinite(t), t, 0.5) * (b - a)

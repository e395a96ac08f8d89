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

MAX_STEPS = 200
NOISE_STEP = 1e-9  # relative step below which steps that stop shrinking are rounding noise
STALL_STEPS = 3  # steps in which a bracket must halve, else it is bisected
EPS = np.finfo(float).eps

# omega -> (h, dh/domega), point k of the k-th root's function
Function = Callable[[NDArray], tuple[NDArray, NDArray]]
# omega -> the rounding bound of h there (below it h's sign is not known)
Noise = Callable[[NDArray], NDArray]


def bracketed_roots(fun: Function, lo: NDArray, hi: NDArray, noise: Noise | None = None) -> NDArray | None:
    """A root of h in each [lo, hi] (0 < lo < hi, h of opposite signs at the ends);
    None when one does not settle within `MAX_STEPS`.  ``noise``: h's rounding
    bound (module docstring)."""
    if lo.size == 0:
        return np.zeros(0)
    a, b = np.log(lo), np.log(hi)
    fa, fb = fun(lo)[0], fun(hi)[0]  # each root's own function: point k belongs to root k
    x = _secant(a, b, fa, fb)
    done, previous = (fa == 0) | (fb == 0), np.full(lo.size, np.inf)
    widths, before = [np.abs(b - a)] * STALL_STEPS, np.full(lo.size, np.inf)
    proposed_before = np.full(lo.size, np.inf)
    x = np.where(fa == 0, a, np.where(fb == 0, b, x))
    for _ in range(MAX_STEPS):
        if done.all():
            return np.exp(x)
        w = np.exp(x)
        h, dh = fun(w)
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
        stalled = (width > 0.5 * widths[0]) & ~(previous < 0.5 * before)  # steps not shrinking either
        widths = widths[1:] + [width]
        tiny = 4 * EPS * np.maximum(1.0, np.abs(x))
        proposed = np.abs(newton - x)  # Newton's step, taken or not (in the noise it leaves the bracket)
        # within 4 ulp the root is reached, even where the step rounds onto the bracket's end
        # (taken as outside, it fell to a secant step 2 % of the bracket away)
        reached = proposed <= tiny
        inside = (inside & ~stalled) | reached
        moved = np.where(inside, newton, np.where(stalled, 0.5 * (a + b), _secant(a, b, fa, fb)))
        size = np.abs(moved - x)
        before = previous
        crawling = (size >= 0.5 * previous) & inside
        settled = reached | (size <= tiny) | (crawling & (size <= NOISE_STEP))
        stuck = (proposed >= 0.5 * proposed_before) & ~settled & ~done
        if noise is not None and stuck.any():  # the bound costs an evaluation: only where it can decide
            settled |= stuck & (np.abs(h) <= noise(w))
        proposed_before = np.where(np.isfinite(proposed), proposed, np.inf)
        finished = settled | (h == 0) | (np.abs(b - a) <= tiny)
        x = np.where(done | (h == 0), x, moved)
        done |= finished
        previous = np.where(inside, size, np.inf)
    return np.exp(x) if done.all() else None


def _secant(a: NDArray, b: NDArray, fa: NDArray, fb: NDArray) -> NDArray:
    """The secant's zero between (a, fa) and (b, fb), kept off the ends (a
    bisection where the values do not allow one; a secant that creeps along the
    bracket is cut short by the stall test)."""
    with np.errstate(all="ignore"):
        t = np.clip(fa / (fa - fb), 0.02, 0.98)
    return a + np.where(np.isfinite(t), t, 0.5) * (b - a)

"""`optimizer="lbfgsb"`: limited-memory BFGS with bounds on the report's scaled
parameters p = b/|b0| (b0 the start), one iteration per step.

scipy's L-BFGS-B (`scipy.optimize.minimize(method="L-BFGS-B")`) runs to the end in
one call and keeps its memory in an internal workspace: it cannot start from a stored
state, so a step could not be replayed from (problem, settings, state).  The step is
therefore made of scipy.optimize's public pieces around a memory we own:
  * bounds p_i >= LOWER (> 0): no parameter changes sign, the sign bound;
  * the projected gradient (components at a bound whose gradient points out are 0)
    and its largest component against ``gtol`` (converged), as L-BFGS-B;
  * the direction -H g of the two-loop recursion over the last ``pairs`` (s, y),
    H0 = (s'y / y'y) I, on the free components; the first step (no pairs) is
    -g/|g|, as L-BFGS-B's first step 1/|g|;
  * L-BFGS-B's own line search: MINPACK's dcsrch (`engine.numerics.line_search`, scipy's, the one
    scipy's L-BFGS-B calls) with L-BFGS-B's constants (ftol 1e-3, gtol 0.9, xtol
    0.1, at most 20 evaluations), the first step 1 (or up to the bound), its
    step capped where a component reaches its bound; when it ends without a
    point meeting its conditions, the best point it tried with sufficient
    decrease (the public `scipy.optimize.line_search`, More-Thuente-free zoom by
    bisection, took 12 halvings from a unit step and failed on the inlet with
    q2 = 0);
  * a pair is kept when s'y > eps_machine y'y (curvature).
The pairs are in the typed memory (`QcgMemory.pairs_s`, ``pairs_y``), so a step
depends only on the state and a replay is exact.  Stops: L-BFGS-B's two tests,
the projected gradient's largest component <= gtol, or F fell by at most ftol
max(|F|, |F_new|, 1) (converged); F did not fall at all (no further improvement:
the line search's point is no lower, or it found none along the projected
gradient; after a failed line search with pairs, they are dropped and the next
step tries the projected gradient); ``limit`` iterations.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from engine.numerics.line_search import DCSRCH
from engine.qcg.cgfm import Move
from engine.qcg.evaluate import Counter, Evaluation
from engine.qcg.memory import QcgMemory
from engine.qcg.settings import QcgSettings
from engine.stepping.protocol import Status

LOWER = 1e-6  # the least p = b/|b0|: a parameter keeps its sign and a millionth of its start
CURVATURE = np.finfo(float).eps
C1, C2, XTOL = 1e-3, 0.9, 0.1  # L-BFGS-B's line search: sufficient decrease, curvature, interval tolerance
MAX_TRIALS = 20  # L-BFGS-B's maxls: cost evaluations of one line search


def lbfgsb_step(settings: QcgSettings, cost: Counter, b: NDArray, memory: QcgMemory) -> Move:
    """One L-BFGS iteration from b, whose cost ``memory.last`` holds."""
    here = memory.last
    scale = np.sign(b) * np.array(memory.initial_scale)
    p, g = b / scale, here.g * scale
    if _projected_norm(p, g) <= settings.gtol:
        return Move(
            b, memory, Status.CONVERGED, f"projected gradient <= gtol = {settings.gtol:g}", here, 0.0, (0.0,) * b.size
        )
    d = _direction(p, g, memory)
    found = _search(cost, scale, p, d, g, here.f)
    if found is None:
        if memory.pairs_s:
            return Move(
                b,
                replace(memory, pairs_s=(), pairs_y=()),
                Status.RUNNING,
                "the line search failed: the pairs are dropped",
                here,
                0.0,
                tuple(d.tolist()),
            )
        return Move(
            b, memory, Status.NO_IMPROVEMENT, "no decrease along the projected gradient", here, 0.0, tuple(d.tolist())
        )
    p_new, new = found
    memory = _remember(replace(memory, kount=memory.kount + 1), p_new - p, new.g * scale - g, settings.pairs)
    status, reason = _stop(settings, memory, here.f, new, p_new, new.g * scale)
    return Move(p_new * scale, memory, status, reason, new, float(np.linalg.norm(p_new - p)), tuple(d.tolist()))


def _projected_norm(p: NDArray, g: NDArray) -> float:
    return float(np.max(np.abs(np.where((p <= LOWER) & (g > 0), 0.0, g))))


def _direction(p: NDArray, g: NDArray, memory: QcgMemory) -> NDArray:
    """-H g on the free components (zero where a bound holds the parameter)."""
    free = (p > LOWER) | (g < 0)
    d = np.zeros(p.size)
    if memory.pairs_s:
        S, Y = np.array(memory.pairs_s)[:, free], np.array(memory.pairs_y)[:, free]
        d[free] = -_two_loop(g[free], S, Y)
    if not memory.pairs_s or d @ g >= 0:  # no pairs, or not a descent direction: steepest descent
        d = np.where(free, -g, 0.0)
        d = d / np.linalg.norm(d)
    return np.where((p <= LOWER) & (d < 0), 0.0, d)


def _two_loop(g: NDArray, S: NDArray, Y: NDArray) -> NDArray:
    """H g for the L-BFGS matrix of the pairs (rows of S, Y, oldest first), H0 = (s'y/y'y) I."""
    q, alphas = g.copy(), []
    for s, y in zip(S[::-1], Y[::-1]):
        rho = 1.0 / (y @ s)
        alphas.append(rho * (s @ q))
        q -= alphas[-1] * y
    r = q * (S[-1] @ Y[-1]) / (Y[-1] @ Y[-1])
    for (s, y), alpha in zip(zip(S, Y), alphas[::-1]):
        r += s * (alpha - (y @ r) / (y @ s))
    return r


def _search(
    cost: Counter, scale: NDArray, p: NDArray, d: NDArray, g: NDArray, f: float
) -> tuple[NDArray, Evaluation] | None:
    """L-BFGS-B's line search along d (MINPACK's dcsrch, `engine.numerics.line_search`, L-BFGS-B's
    constants), capped at the bounds: the new p and its cost.  When it ends without a
    point meeting its conditions, the best point it tried with sufficient decrease."""

    seen: dict[float, Evaluation | None] = {}

    def at(alpha: float) -> Evaluation | None:
        if alpha not in seen:
            seen[alpha] = cost.attempt(_point(p, alpha, d) * scale)
        return seen[alpha]

    def value(alpha: float) -> float:
        e = at(alpha)
        return np.inf if e is None else e.f

    def slope(alpha: float) -> float:
        e = at(alpha)
        return np.nan if e is None else float(e.g * scale @ d)

    falling = d < 0
    amax = float(np.min((p[falling] - LOWER) / -d[falling])) if falling.any() else 1e10
    search = DCSRCH(value, slope, C1, C2, XTOL, 0.0, amax)
    with np.errstate(all="ignore"):
        alpha = search(min(1.0, amax), phi0=f, derphi0=float(g @ d), maxiter=MAX_TRIALS)[0]
    if alpha is None:
        decrease = [(e.f, a) for a, e in seen.items() if e is not None and e.f <= f + C1 * a * float(g @ d)]
        if not decrease:
            return None
        alpha = min(decrease)[1]
    return _point(p, alpha, d), at(alpha)


def _point(p: NDArray, alpha: float, d: NDArray) -> NDArray:
    return np.maximum(p + alpha * d, LOWER)


def _remember(memory: QcgMemory, s: NDArray, y: NDArray, keep: int) -> QcgMemory:
    """The pair (s, y) added (the oldest dropped beyond ``keep``) when its curvature is positive."""
    if not s @ y > CURVATURE * (y @ y):
        return memory
    return replace(
        memory,
        pairs_s=(memory.pairs_s + (tuple(s.tolist()),))[-keep:],
        pairs_y=(memory.pairs_y + (tuple(y.tolist()),))[-keep:],
    )


def _stop(
    settings: QcgSettings, memory: QcgMemory, f_old: float, new: Evaluation, p: NDArray, g: NDArray
) -> tuple[Status, str]:
    if _projected_norm(p, g) <= settings.gtol:
        return Status.CONVERGED, f"projected gradient <= gtol = {settings.gtol:g}"
    if not new.f < f_old:
        return Status.NO_IMPROVEMENT, "no decrease along the search direction (F did not fall)"
    if f_old - new.f <= settings.ftol * max(abs(f_old), abs(new.f), 1.0):
        return Status.CONVERGED, f"F fell by less than ftol = {settings.ftol:g} (relative; L-BFGS-B's factr test)"
    if memory.kount >= settings.limit:
        return Status.ITERATION_LIMIT, f"limit = {settings.limit} iterations"
    return Status.RUNNING, ""

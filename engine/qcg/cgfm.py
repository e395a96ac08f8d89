"""Report 001's scaled, sign-constrained Fletcher-Reeves search (CGFM): one line search.

The listing (CGFM), read as follows where the scan is unclear:
  * scaled parameters p = b / lambda with lambda_i = |b_i| at the start of
    each iteration; the gradient is Lambda dF/db; the direction is
    h = -g + beta h_prev (beta = |g|^2/|g_prev|^2, 0 on a restart);
  * the step is normalized so that sum |scale h_i| = SIZE, and a trial is
    b_i = b0_i |1 + scale h_i|: no parameter changes sign;
  * line search: while the cost falls, scale *= STEP (2), at most 15 times
    (else IER = 2); if the first trial rises, scale /= (1 + STEP) and SIZE
    too, once; then a parabola through the three bracketing points gives
    each b_i.  The listing's "IF(L.GT.3)" that moves the first point of the
    parabola to the previous trial reads "L >= 3" here: only then are the
    three points the ones whose costs are used (checked on the sample);
  * a fitted b_i of the wrong sign becomes a tenth of the last trial's b_i;
  * SIZE *= (L + 2)/4 after a line search; a restart (beta = 0) after N + 1
    iterations, and after a failed contraction (b restored, SIZE /= 3);
  * stop: KOUNT >= LIMIT (IER 1), SIZE < EPS (IER 0, converged), 15
    expansions (IER 2, failed), tested after each line search.
Beyond the listing: a zero scaled gradient (no descent direction) stops with
"no further improvement", not IER 0: the report's test SIZE < EPS was not met.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.qcg.evaluate import Counter, Evaluation
from engine.qcg.memory import QcgMemory
from engine.qcg.settings import QcgSettings
from engine.stepping.protocol import Status


class Search(NamedTuple):
    """A line search's outcome ("ok", "restart" or "failed"), its point and the new SIZE."""

    b: NDArray
    outcome: str
    size: float


class Move(NamedTuple):
    """What a step of either optimizer did: the new point and memory (counters not yet
    advanced), how the run stands, the cost at the point, and the step's size, direction
    and (CGFM) beta."""

    b: NDArray
    memory: QcgMemory
    status: Status
    reason: str
    last: Evaluation
    step_size: float
    direction: tuple[float, ...]
    beta: float | None = None


def cgfm_step(settings: QcgSettings, cost: Counter, b0: NDArray, memory: QcgMemory) -> Move:
    """One line search of CGFM from b0, whose cost ``memory.last`` holds."""
    s, here = settings, memory.last
    lam = _scale(s.scaling, b0, memory)
    g = here.g * lam
    tsqr = float(g @ g)
    if not np.isfinite(tsqr):
        raise EngineError("qcg: the scaled gradient overflows (the cost's scale is beyond floating point)")
    beta = tsqr / memory.tsave if memory.ncyc else 0.0
    h = -g + beta * np.array(memory.direction)
    total = float(np.abs(h).sum())
    if total <= 0:
        return Move(
            b0,
            memory,
            Status.NO_IMPROVEMENT,
            "zero gradient: no descent direction",
            here,
            memory.size,
            memory.direction,
        )
    memory = replace(memory, tsave=tsqr, ncyc=memory.ncyc + 1, direction=tuple(h.tolist()))
    search = _line_search(s, cost, b0, here.f, h, memory.size / total, lam, memory.size)
    memory = replace(memory, size=search.size, kount=memory.kount + (search.outcome == "ok"))
    if search.outcome == "failed":
        return Move(
            b0,
            memory,
            Status.FAILED,
            f"{s.max_expansions} step expansions without a minimum (IER = 2)",
            here,
            memory.size,
            memory.direction,
            beta,
        )
    direction = memory.direction
    if search.outcome == "restart" or memory.ncyc > b0.size:
        memory = replace(memory, ncyc=0, direction=(0.0,) * b0.size)
    last = here if search.outcome == "restart" else cost.full(search.b)
    status, reason = Status.RUNNING, ""
    if memory.kount >= s.limit:
        status, reason = Status.ITERATION_LIMIT, "LIMIT line searches (IER = 1)"
    elif memory.size < s.eps:
        status, reason = Status.CONVERGED, f"SIZE < EPS = {s.eps:g} (IER = 0)"
    return Move(search.b, memory, status, reason, last, memory.size, direction, beta)


def _line_search(
    s: QcgSettings, cost: Counter, b0: NDArray, f0: float, h: NDArray, scale: float, lam: NDArray, size: float
) -> Search:
    """The listing's expansion/contraction and three-point parabola."""
    fss, f, L, K, scasv = f0, f0, 1, 0, scale
    while True:
        trial = _trial(s.scaling, b0, scale, h, lam)
        fs, f = f, cost.value(trial)
        if K > 0:
            if f < fss:
                break
            return Search(b0, "restart", size / (1 + s.step))
        if f < fs:
            scasv, L, scale, fss = scale, L + 1, scale * s.step, fs
            if L >= s.max_expansions:
                return Search(b0, "failed", size)
            continue
        if L > 1:
            break
        scasv, scale, K = scale, scale / (1 + s.step), K + 1
        size /= 1 + s.step
    r1 = _trial(s.scaling, b0, scasv / s.step, h, lam) if L >= 3 else b0
    r2, r3 = _trial(s.scaling, b0, scasv, h, lam), trial
    x1, x2 = (fss - fs) * (r1 - r3), (fss - f) * (r2 - r1)
    with np.errstate(all="ignore"):
        fitted = (x1 * (r1 + r3) + x2 * (r1 + r2)) / ((x1 + x2) * 2)
    still = np.abs(r2 - r3) <= s.eps / 4
    b = np.where(still, r2 if L > 1 else r3, fitted)
    b = np.where((b * b0 <= 0) | ~np.isfinite(b), 0.1 * r3, b)
    return Search(b, "ok", size * ((L + 2) / 4))


def _trial(scaling: str, b0: NDArray, scale: float, h: NDArray, lam: NDArray) -> NDArray:
    if scaling == "iteration":
        return b0 * np.abs(1.0 + scale * h)
    b = b0 + lam * scale * h
    return np.where(b * b0 > 0, b, 0.1 * b0)  # the sign bound


def _scale(scaling: str, b: NDArray, memory: QcgMemory) -> NDArray:
    if scaling == "iteration":
        return np.abs(b)
    return np.array(memory.initial_scale) if scaling == "initial" else np.ones(b.size)

"""`qcg`: report 001's scaled, sign-constrained Fletcher-Reeves search (CGFM)
on the quadratic cost of `cost.py`.  One `step` is one line search.

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
  * stop: SIZE < EPS (IER 0, converged), KOUNT >= LIMIT (IER 1), 15
    expansions (IER 2, failed).
KNT counts cost evaluations, KOUNT line searches, as the listing does.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..algorithm import MeasureRow, State, Status, StepRecord
from ..errors import EngineError
from ..guard import check_vector, guarded
from ..problem import Problem
from .memory import QcgMemory
from .setup import CascadeProblem, cascade_problem


class Search(NamedTuple):
    """A line search's outcome ("ok", "restart" or "failed"), its point, the new SIZE,
    and the cost evaluations it made."""

    b: NDArray
    outcome: str
    size: float
    evaluations: int


@dataclass(frozen=True)
class QcgSettings:
    """The listing's SIZE, EPS, LIMIT, STEP, and the scaling rule."""

    size: float = 0.1
    eps: float = 1e-5
    limit: int = 50
    step: float = 2.0
    max_expansions: int = 15
    scaling: Literal["iteration", "initial", "none"] = "iteration"

    def __post_init__(self) -> None:
        if self.scaling not in ("iteration", "initial", "none"):
            raise EngineError(f"qcg: scaling must be 'iteration', 'initial' or 'none', not {self.scaling!r}")
        if not (self.size > 0 and self.eps > 0 and self.step > 1 and self.limit >= 1):
            raise EngineError("qcg: need size > 0, eps > 0, step > 1, limit >= 1")


class Qcg:
    """The stepper (see the module docstring)."""

    name = "qcg"
    memory_type = QcgMemory

    @guarded('qcg')
    def init(self, problem: Problem, settings: QcgSettings) -> State:
        self.problem, self.settings = problem, settings
        self.cascade: CascadeProblem = cascade_problem(problem)
        x = problem.vector()
        if x.size == 0:
            raise EngineError("qcg: no free parameters")
        if np.any(x == 0):
            raise EngineError("qcg: a free parameter is zero; the search keeps every sign, so start away from 0")
        memory = QcgMemory(size=settings.size, ncyc=0, tsave=0.0, direction=(0.0,) * x.size, knt=0, kount=0,
                           initial_scale=tuple(np.abs(x).tolist()))
        return State(0, tuple(x.tolist()), Status.RUNNING, memory)

    # -- one line search --------------------------------------------------

    @guarded('qcg')
    def step(self, state: State) -> tuple[State, StepRecord]:
        s = self.settings
        check_vector("qcg", state.x, len(self._names()))
        b0 = np.array(state.x)
        f, g = self._cost(b0, gradient=True)
        memory: QcgMemory = replace(state.memory, knt=state.memory.knt + 1)
        if memory.kount >= s.limit:
            return self._finish(state, memory, b0, f, Status.ITERATION_LIMIT, "LIMIT line searches (IER = 1)")
        if memory.size < s.eps:
            return self._finish(state, memory, b0, f, Status.CONVERGED, f"SIZE < EPS = {s.eps:g} (IER = 0)")
        lam = self._scale(b0, memory)
        g = g * lam
        tsqr = float(g @ g)
        if not np.isfinite(tsqr):
            raise EngineError("qcg: the scaled gradient overflows (the cost's scale is beyond floating point)")
        beta = tsqr / memory.tsave if memory.ncyc else 0.0
        h = -g + beta * np.array(memory.direction)
        total = float(np.abs(h).sum())
        if total <= 0:
            return self._finish(state, memory, b0, f, Status.CONVERGED, "zero gradient (IER = 0)")
        memory = replace(memory, tsave=tsqr, ncyc=memory.ncyc + 1, direction=tuple(h.tolist()))
        search = self._line_search(b0, f, h, memory.size / total, lam, memory.size)
        memory = replace(memory, size=search.size, knt=memory.knt + search.evaluations,
                         kount=memory.kount + (search.outcome == "ok"))
        if search.outcome == "failed":
            return self._finish(state, memory, b0, f, Status.FAILED,
                                f"{s.max_expansions} step expansions without a minimum (IER = 2)")
        if search.outcome == "restart" or memory.ncyc > b0.size:
            memory = replace(memory, ncyc=0, direction=(0.0,) * b0.size)
        new_state = State(state.iteration + 1, tuple(search.b.tolist()), Status.RUNNING, memory)
        return new_state, self._record(new_state, search.b, memory, Status.RUNNING, "", beta)

    def _line_search(self, b0: NDArray, f0: float, h: NDArray, scale: float, lam: NDArray,
                     size: float) -> Search:
        """The listing's expansion/contraction and three-point parabola."""
        s = self.settings
        fss, f, L, K, scasv, evaluations = f0, f0, 1, 0, scale, 0
        while True:
            trial = self._trial(b0, scale, h, lam)
            fs, f = f, self._cost(trial, gradient=False)[0]
            evaluations += 1
            if K > 0:
                if f < fss:
                    break
                return Search(b0, "restart", size / (1 + s.step), evaluations)
            if f < fs:
                scasv, L, scale, fss = scale, L + 1, scale * s.step, fs
                if L >= s.max_expansions:
                    return Search(b0, "failed", size, evaluations)
                continue
            if L > 1:
                break
            scasv, scale, K = scale, scale / (1 + s.step), K + 1
            size /= 1 + s.step
        r1 = self._trial(b0, scasv / s.step, h, lam) if L >= 3 else b0
        r2, r3 = self._trial(b0, scasv, h, lam), trial
        x1, x2 = (fss - fs) * (r1 - r3), (fss - f) * (r2 - r1)
        with np.errstate(all="ignore"):
            fitted = (x1 * (r1 + r3) + x2 * (r1 + r2)) / ((x1 + x2) * 2)
        still = np.abs(r2 - r3) <= s.eps / 4
        b = np.where(still, r2 if L > 1 else r3, fitted)
        b = np.where((b * b0 <= 0) | ~np.isfinite(b), 0.1 * r3, b)
        return Search(b, "ok", size * ((L + 2) / 4), evaluations)

    def _trial(self, b0: NDArray, scale: float, h: NDArray, lam: NDArray) -> NDArray:
        if self.settings.scaling == "iteration":
            return b0 * np.abs(1.0 + scale * h)
        b = b0 + lam * scale * h
        return np.where(b * b0 > 0, b, 0.1 * b0)   # the sign constraint

    def _scale(self, b: NDArray, memory: QcgMemory) -> NDArray:
        rule = self.settings.scaling
        if rule == "iteration":
            return np.abs(b)
        return np.array(memory.initial_scale) if rule == "initial" else np.ones(b.size)

    def _cost(self, b: NDArray, gradient: bool) -> tuple[float, NDArray]:
        """F at b (and its gradient); the caller counts the evaluation (KNT)."""
        result = self.cascade.cost(self.problem.condition_values(0, b), gradient)
        g = np.array([result.gradient[n] for n in self._names()]) if gradient else np.zeros(0)
        if not (np.isfinite(result.F) and np.all(np.isfinite(g))):
            if not gradient:
                return np.inf, g     # a trial where the cost overflows is no improvement
            raise EngineError(f"qcg: the cost or its gradient is not finite at {self.problem.named(b)}")
        return result.F, g

    def _names(self) -> list[str]:
        return [self.problem.parameters[i].name for i, _ in self.problem.free_slots()]

    # -- records ----------------------------------------------------------

    def _finish(self, state: State, memory: QcgMemory, b: NDArray, f: float, status: Status,
                reason: str) -> tuple[State, StepRecord]:
        new_state = State(state.iteration + 1, state.x, status, memory)
        return new_state, self._record(new_state, b, memory, status, reason, None)

    def _record(self, state: State, b: NDArray, memory: QcgMemory, status: Status, reason: str,
                beta: float | None) -> StepRecord:
        params = self.problem.condition_values(0, b)
        result = self.cascade.cost(params, gradient=False)
        squares = self.cascade.averaged_squares(params)
        rows = tuple(MeasureRow(name, "averaged_square", self.problem.conditions[0].name, value, None, True)
                     for name, value in squares.items())
        extra = {"F": result.F, "C": result.C, "parts": result.parts, "refined_intervals": result.refined_intervals,
                 "size": memory.size, "beta": beta, "averaged_squares": squares,
                 "conventions": "F = sum F(w_i)(w_{i+1} - w_{i-1}) as the listing prints; C = F/(2 pi), eq. (22)"}
        return StepRecord(state.iteration, status, self.problem.named(b), rows, objective=result.C,
                          step_size=memory.size, direction=memory.direction,
                          counters={"KNT": memory.knt, "KOUNT": memory.kount, "evaluations": memory.knt,
                                    "line_searches": memory.kount},
                          reason=reason, extra=extra)

"""`qcg`: report 001's quadratic cost (`cost.py`) minimized by CGFM (`cgfm.py`, the
report's method and the default: one step is one line search) or by L-BFGS with
bounds (`lbfgsb.py`, ``optimizer="lbfgsb"``: one step is one iteration).

Counting (every call of the cost formula, `evaluate.py`): `init` evaluates the
open-loop reference of the normalized averaged squares (one evaluation) and F with
its gradient at the start; a step reuses the cost at its starting point from the
memory, counts its trials and line-search points, and ends with F and the gradient
at its new point, from which its record is made (parts, averaged squares) and which
the next step starts from.  Counters: KNT (the search's evaluations, the listing's
counter), ``evaluations`` (all of them, the open-loop reference included),
``gradients`` (those with the gradient), KOUNT (line searches, iterations).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from engine.errors import EngineError
from engine.qcg.cgfm import Move, cgfm_step
from engine.qcg.cost import CostResult, normalized_squares, open_loop_squares
from engine.qcg.evaluate import PARTS, SQUARES, Counter, Evaluation, counted
from engine.qcg.lbfgsb import lbfgsb_step
from engine.qcg.memory import QcgMemory
from engine.qcg.settings import QcgSettings
from engine.qcg.setup import CascadeProblem, cascade_problem
from engine.stepping.guard import check_vector, guarded
from engine.stepping.protocol import BoundStepper, MeasureRow, State, Status, StepRecord

__all__ = ["Qcg", "QcgSettings"]
CONVENTIONS = "F = sum F(w_i)(w_{i+1} - w_{i-1}) as the listing prints; C = F/(2 pi), eq. (22)"


class Qcg(BoundStepper):
    """The stepper (see the module docstring)."""

    name = "qcg"
    memory_type = QcgMemory
    settings: QcgSettings

    @guarded("qcg")
    def setup(self) -> None:
        problem = self.problem
        self.cascade: CascadeProblem = cascade_problem(problem)
        x = problem.vector()
        if x.size == 0:
            raise EngineError("qcg: no free parameters")
        if np.any(x == 0):
            raise EngineError("qcg: a free parameter is zero; the search keeps every sign, so start away from 0")
        self.open_loop = open_loop_squares(self.cascade.cascade)

    @guarded("qcg")
    def init(self) -> State:
        """The first state, with the cost at the start."""
        problem, settings, x = self.problem, self.settings, self.problem.vector()
        cost = Counter(self.cascade, problem, self._names())
        last = cost.full(x)
        memory = QcgMemory(
            size=settings.size,
            ncyc=0,
            tsave=0.0,
            direction=(0.0,) * x.size,
            knt=cost.evaluations,
            kount=0,
            initial_scale=tuple(np.abs(x).tolist()),
            evaluations=cost.evaluations + 1,
            gradients=cost.gradients,
            last=last,
        )
        return State(0, tuple(x.tolist()), Status.RUNNING, memory)

    @guarded("qcg")
    def step(self, state: State) -> tuple[State, StepRecord]:
        """One line search (CGFM) or one iteration (lbfgsb)."""
        check_vector("qcg", state.x, len(self._names()))
        b0 = np.array(state.x)
        cost = Counter(self.cascade, self.problem, self._names())
        memory: QcgMemory = state.memory
        if memory.last is None or memory.last.at != state.x:  # a state whose point was set from outside
            memory = replace(memory, last=cost.full(b0))
        optimizer = cgfm_step if self.settings.optimizer == "cgfm" else lbfgsb_step
        move = optimizer(self.settings, cost, b0, memory)
        memory = replace(move.memory, last=move.last, **counted(move.memory, cost))
        new_state = State(state.iteration + 1, tuple(move.b.tolist()), move.status, memory)
        return new_state, self._record(new_state, move)

    def _names(self) -> list[str]:
        return [self.problem.parameters[i].name for i, _ in self.problem.free_slots()]

    def _record(self, state: State, move: Move) -> StepRecord:
        """The record of the step's new point, from the cost the step computed there."""
        memory: QcgMemory = state.memory
        result = _result(memory.last)
        squares = normalized_squares(result.squares, self.open_loop)
        rows = tuple(
            MeasureRow(name, "averaged_square", self.problem.conditions[0].name, value, None, True)
            for name, value in squares.items()
        )
        extra = {
            "F": result.F,
            "C": result.C,
            "parts": result.parts,
            "refined_intervals": result.refined_intervals,
            "size": memory.size,
            "beta": move.beta,
            "averaged_squares": squares,
            "optimizer": self.settings.optimizer,
            "conventions": CONVENTIONS,
        }
        return StepRecord(
            state.iteration,
            state.status,
            self.problem.named(move.b),
            rows,
            objective=result.C,
            step_size=move.step_size,
            direction=move.direction,
            counters={
                "KNT": memory.knt,
                "KOUNT": memory.kount,
                "evaluations": memory.evaluations,
                "gradients": memory.gradients,
                "line_searches": memory.kount,
            },
            reason=move.reason,
            extra=extra,
        )


def _result(last: Evaluation) -> CostResult:
    return CostResult(last.f, dict(zip(PARTS, last.parts)), None, last.refined, dict(zip(SQUARES, last.squares)))

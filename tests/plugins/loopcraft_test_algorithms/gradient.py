"""A small real algorithm, kept in the tests, to exercise the protocol, the
schema and the CLI before the report algorithms land: Gauss-Newton with
backtracking on a model-matching cost

    J(x) = mean over the grid and conditions of |GH(j w; x) - R(j w)|^2 / |R(j w)|^2,

R given by the objective's ``reference`` expression; the Jacobian of the
residuals comes from the engine's analytic sensitivities.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from engine.design.measure_kinds import TargetUse
from engine.design.tableau import tableau
from engine.errors import EngineError
from engine.loop.responses import open_loop
from engine.model.expressions import Expression
from engine.stepping.memory_fields import Fields
from engine.stepping.protocol import BoundStepper, State, Status, StepRecord
from engine.stepping.registry import Registration


@dataclass(frozen=True)
class GradientSettings:
    step: float = 1.0
    tolerance: float = 1e-6
    max_halvings: int = 30


@dataclass(frozen=True)
class GradientMemory:
    """The step to try first."""

    step: float

    def to_json(self) -> dict:
        return {"step": self.step}

    @classmethod
    def from_json(cls, data: Any) -> GradientMemory:
        step = Fields(data, "gradient memory").number("step")
        if not step > 0:
            raise EngineError(f"gradient memory.step: expected a number > 0, got {step!r}")
        return cls(step)


class GradientDescent(BoundStepper):
    name = "gradient"
    memory_type = GradientMemory
    settings: GradientSettings

    def setup(self) -> None:
        self.reference = Expression(str(self.problem.objective.options["reference"]))

    def init(self) -> State:
        return State(0, tuple(self.problem.vector()), Status.RUNNING, GradientMemory(self.settings.step))

    def residuals(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Scaled residuals (real and imaginary parts) and their Jacobian."""
        p = self.problem.with_vector(x)
        slots = p.free_slots()
        w = p.grid.omega
        ref = self.reference.evaluate(1j * w, {}).value
        scale = 1.0 / (np.abs(ref) * np.sqrt(w.size * len(p.conditions)))
        res, jac = [], []
        for c, cond in enumerate(p.conditions):
            r = open_loop(cond.network, cond.break_at, w, p.condition_values(c))
            J = np.zeros((w.size, len(slots)), dtype=complex)
            for k, (i, slot_c) in enumerate(slots):
                name = p.parameters[i].name
                if (slot_c is None or slot_c == c) and name in r.parameters:
                    J[:, k] = r.sensitivity[:, r.parameters.index(name)] * scale
            err = (r.value - ref) * scale
            res += [err.real, err.imag]
            jac += [J.real, J.imag]
        return np.concatenate(res), np.vstack(jac)

    def cost(self, x: np.ndarray) -> float:
        return float(np.sum(self.residuals(x)[0] ** 2))

    def step(self, state: State) -> tuple[State, StepRecord]:
        x = np.array(state.x)
        r, J = self.residuals(x)
        j0 = float(np.sum(r**2))
        g = np.linalg.lstsq(J, -r, rcond=None)[0]  # the Gauss-Newton direction
        step, evaluations = float(state.memory.step), 1
        status = Status.RUNNING
        for _ in range(0 if j0 < 1e-24 else self.settings.max_halvings):  # nothing left to match
            trial = x + step * g
            j1 = self.cost(trial)
            evaluations += 1
            if j1 < j0:
                break
            step *= 0.5
        else:
            trial, j1 = x, j0
            status = Status.CONVERGED if j0 < 1e-24 else Status.STEP_BELOW_MINIMUM
        if status is Status.RUNNING and j0 - j1 <= self.settings.tolerance * max(j0, 1e-300):
            status = Status.CONVERGED
        problem = self.problem.with_vector(trial)
        record = StepRecord(
            iteration=state.iteration + 1,
            status=status,
            parameters=problem.named(),
            measures=tuple(tableau(problem)),
            objective=j1,
            step_size=step,
            direction=tuple(g / (np.linalg.norm(g) or 1.0)),
            counters={"evaluations": evaluations},
        )
        return State(state.iteration + 1, tuple(trial), status, GradientMemory(min(step * 2, 1.0))), record


REGISTRATION = Registration(
    name="gradient",
    bind=GradientDescent.bind,
    settings=GradientSettings,
    memory_type=GradientMemory,
    summary="Gauss-Newton on a model-matching cost (tests only)",
    targets=TargetUse(reads=False, refusal="is not read by gradient (it matches its reference response)"),
)

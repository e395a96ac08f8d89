"""`projection`: sequential projection with extrapolation (report 004, Theorem 2).

K1 = the boxes on u and x, K2 = the dynamics with the algebraic equations.
r_1 = P_K2(0) (the LQ solution with zero reference); one `step`:
    k_i = P_K1(r_i)  (clipping: exact for diagonal Q, R),
    s_i = P_K2(k_i)  (the banded KKT solve, `banded.py`),
    lambda_i = ||k_i - r_i||^2 / ||s_i - r_i||^2   (>= 1),
    r_{i+1} = r_i + lambda_i (s_i - r_i).
Reset rule (the reactor example): "lambda_k = 1 whenever prod_{i=l}^{k}
lambda_i > 1e3, where l was the previous iteration at which lambda was set
to unity".  Read here as: the product of the lambdas *applied* since the
last reset (lambda_l .. lambda_{k-1}) is tested before step k, so the step
that takes the product over the limit is still made and the next one has
lambda = 1 (which starts the product anew).  This is the reading that gives
the report's Table 2 (lambda = 34.6, 59.6, 1, 1); testing the product with
the candidate lambda_k included would set lambda_2 = 1.
`final_unit_step` (the reactor example: "lambda was also set to unity on
the final (converged) iteration"): when r_i passes the test, the iteration
still projects, r_{i+1} = s_i = P_K2(P_K1(r_i)), and that is the answer.
Without it the answer is r_i (in K2 exactly; the test asks the bounds to
hold to the tolerance as well).  `extrapolation = False` gives lambda = 1
always (Theorem 1).  Converged when ||k_i - r_i|| <= tolerance ||r_i|| and
every bound holds to tolerance; when the distance stops falling (the sets
are disjoint) the status is infeasible, with the distance and the bounds
that bind.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from engine.errors import EngineError
from engine.projection.banded import Projector
from engine.projection.lq import Trajectory, norm
from engine.projection.memory import Iterate, ProjectionMemory
from engine.projection.openloop import open_loop, peak_rows, peaks
from engine.projection.system import DaeSystem, dae_system
from engine.stepping.guard import guarded
from engine.stepping.protocol import BoundStepper, MeasureRow, State, Status, StepRecord

STALL_WINDOW = 6


@dataclass(frozen=True)
class ProjectionSettings:
    extrapolation: bool = True
    reset_product: float = 1e3
    final_unit_step: bool = False  # lambda = 1 on the converged iteration, its s the answer (report 004's reactor)
    tolerance: float = 1e-8
    max_iterations: int = 500
    stall: float = 1e-9  # relative fall of the distance over STALL_WINDOW iterations below this: disjoint

    def __post_init__(self) -> None:
        if not (self.tolerance > 0 and self.reset_product >= 1 and self.max_iterations >= 1):
            raise EngineError("projection: need tolerance > 0, reset_product >= 1, max_iterations >= 1")


class Projection(BoundStepper):
    name = "projection"
    memory_type = ProjectionMemory
    settings: ProjectionSettings

    @guarded("projection")
    def setup(self) -> None:
        problem = self.problem
        if problem.objective is None or problem.objective.kind != "dae":
            raise EngineError("projection: the problem needs an objective of kind 'dae' with the system in its data")
        if problem.inequalities:
            raise EngineError(
                "projection: linear constraints between parameters (problem.constraints) do not "
                "apply: its unknowns are the trajectories and controls of the DAE, whose bounds are "
                "in the objective's data; remove the constraints"
            )
        self.system: DaeSystem = dae_system(problem.objective.data)
        self.project = Projector(self.system)
        self.open_loop = (
            None if self.system.open_loop is None else open_loop(self.system, self.project.Phi, self.project.Delta)
        )
        self._hyperplanes()
        self._times = self.system.times().tolist()
        self._open_rows = None if self.open_loop is None else self.open_loop.packed

    @guarded("projection")
    def init(self) -> State:
        zero = Trajectory(
            np.zeros((self.system.steps + 1, self.system.n)), np.zeros((self.system.steps + 1, self.system.m))
        )
        return State(0, (), Status.RUNNING, ProjectionMemory(self._pack(self.project(zero)), 1.0, ()))

    @guarded("projection")
    def initial_record(self, state: State) -> StepRecord:
        """Iteration 0: the first iterate r_1 = P_K2(0), with the open loop where the system defines one."""
        r = self._unpack(state.memory.r)
        return self._record(0, Status.RUNNING, "", r, None, norm(self._clip(r) - r, self.system.Q, self.system.R), None)

    @guarded("projection")
    def step(self, state: State) -> tuple[State, StepRecord]:
        s, sys = self.settings, self.system
        memory: ProjectionMemory = state.memory
        r = self._unpack(memory.r)
        k = self._clip(r)
        distance = norm(k - r, sys.Q, sys.R)
        i = state.iteration + 1
        if not np.isfinite(distance):
            raise EngineError(
                "projection: the distance between the sets overflows (the system's scale is beyond floating point)"
            )
        history = memory.distances + (distance,)
        memory = replace(memory, distances=history[-STALL_WINDOW - 1 :])
        if self._converged(r, distance):
            return self._converge(memory, r, k, distance, i)
        stalled = len(history) > STALL_WINDOW and history[-STALL_WINDOW - 1] - distance <= s.stall * distance
        if stalled and s.extrapolation and not memory.plain:
            # disjoint sets: lambda = 1 finds the closest pair
            memory = replace(memory, plain=True, distances=(distance,))
            stalled = False
        if stalled:
            return self._finish(
                memory,
                r,
                Status.INFEASIBLE,
                f"the sets do not meet: the distance stays at "
                f"{distance:.6g}; binding: {', '.join(self._binding(r)) or 'none'}",
                i,
                distance,
            )
        if i > s.max_iterations:
            return self._finish(memory, r, Status.ITERATION_LIMIT, f"{s.max_iterations} iterations", i, distance)
        proj = self.project(k)
        lam, product = self._lambda(memory, distance, norm(proj - r, sys.Q, sys.R) ** 2)
        new = r + (proj - r).scaled(lam)
        memory = replace(memory, r=self._pack(new), product=product)
        return State(i, (), Status.RUNNING, memory), self._record(
            i, Status.RUNNING, "", new, lam, distance, norm(k - proj, sys.Q, sys.R)
        )

    # -- pieces -----------------------------------------------------------

    def _lambda(self, memory: ProjectionMemory, distance: float, denominator: float) -> tuple[float, float]:
        """(lambda_i, the new product): lambda_i = ||k - r||^2 / ||s - r||^2, or 1 (no extrapolation,
        disjoint sets, or the reset; the reading of the reset rule is in the module docstring)."""
        s = self.settings
        if memory.product > s.reset_product:
            return 1.0, 1.0
        extrapolate = s.extrapolation and not memory.plain and denominator > 0
        lam = distance**2 / denominator if extrapolate else 1.0
        return lam, memory.product * lam

    def _converged(self, r: Trajectory, distance: float) -> bool:
        s = self.settings
        scale = max(norm(r, self.system.Q, self.system.R), 1e-300)
        return distance <= s.tolerance * scale and list(self.violations(r).values())[-1] <= s.tolerance * max(
            1.0, _scale(r)
        )

    def _converge(
        self, memory: ProjectionMemory, r: Trajectory, k: Trajectory, distance: float, i: int
    ) -> tuple[State, StepRecord]:
        reason = (
            f"distance between the sets {distance:.3g} <= {self.settings.tolerance:g} x ||r||, every bound "
            "met to the tolerance"
        )
        if not self.settings.final_unit_step:
            return self._finish(memory, r, Status.CONVERGED, reason, i, distance)
        sys = self.system
        answer = self.project(k)  # lambda = 1 on the final iteration: r_{i+1} = s_i
        memory = replace(memory, r=self._pack(answer))
        record = self._record(
            i,
            Status.CONVERGED,
            reason + "; lambda = 1 on this final iteration",
            answer,
            1.0,
            distance,
            norm(k - answer, sys.Q, sys.R),
        )
        return State(i, (), Status.CONVERGED, memory), record

    def _hyperplanes(self) -> None:
        """For P_K1 onto c . vec(u) = d in the R norm: C R^-1 (block diagonal, never formed) and C R^-1 C'."""
        sys = self.system
        if sys.integral is None:
            return
        C = sys.integral
        if np.linalg.matrix_rank(C) < C.shape[0]:
            raise EngineError(
                "projection: the integral constraints are not independent (a singular Gram matrix): "
                "drop the repeated ones"
            )
        self._CRinv = (C.reshape(C.shape[0], sys.steps + 1, sys.m) @ np.linalg.inv(sys.R)).reshape(C.shape)
        self._gram = self._CRinv @ C.T

    def _clip(self, t: Trajectory) -> Trajectory:
        """P_K1: clipping onto the boxes, or the R-norm projection onto the integral hyperplanes."""
        sys = self.system
        if sys.integral is not None:
            u = t.u.ravel()
            u = u - self._CRinv.T @ np.linalg.solve(self._gram, sys.integral @ u - sys.integral_values)
            return Trajectory(t.x, u.reshape(t.u.shape))
        return Trajectory(np.clip(t.x, sys.x_lower, sys.x_upper), np.clip(t.u, sys.u_lower, sys.u_upper))

    def _binding(self, t: Trajectory) -> list[str]:
        sys, names = self.system, []
        for j in range(sys.m):
            if np.any(t.u[:, j] < sys.u_lower[j]) or np.any(t.u[:, j] > sys.u_upper[j]):
                names.append(f"u{j + 1}")
        for j in range(sys.n):
            if np.any(t.x[:, j] < sys.x_lower[j]) or np.any(t.x[:, j] > sys.x_upper[j]):
                names.append(f"x{j + 1}")
        return names

    def violations(self, t: Trajectory) -> dict[str, float]:
        """Largest violation of the dynamics, of E u + F x = 0, and of the bounds."""
        sys, P = self.system, self.project
        dyn = t.x[1:] - t.x[:-1] @ P.Phi.T - t.u[:-1] @ P.Delta.T
        alg = t.u @ sys.E.T + t.x @ sys.F.T
        if sys.integral is not None:
            bounds = float(np.abs(sys.integral @ t.u.ravel() - sys.integral_values).max())
            return {
                "dynamics": float(np.abs(dyn).max(initial=0)),
                "algebraic": float(np.abs(alg).max(initial=0)),
                "hyperplanes": bounds,
            }
        bounds = max(
            float(np.max(np.maximum(sys.u_lower - t.u, 0), initial=0)),
            float(np.max(np.maximum(t.u - sys.u_upper, 0), initial=0)),
            float(np.max(np.maximum(sys.x_lower - t.x, 0), initial=0)),
            float(np.max(np.maximum(t.x - sys.x_upper, 0), initial=0)),
        )
        return {
            "dynamics": float(np.abs(dyn).max(initial=0)),
            "algebraic": float(np.abs(alg).max(initial=0)),
            "bounds": bounds,
        }

    def _finish(
        self, memory: ProjectionMemory, r: Trajectory, status: Status, reason: str, i: int, distance: float
    ) -> tuple[State, StepRecord]:
        return State(i, (), status, memory), self._record(i, status, reason, r, None, distance, None)

    def _record(
        self,
        i: int,
        status: Status,
        reason: str,
        r: Trajectory,
        lam: float | None,
        distance: float,
        k_to_s: float | None,
    ) -> StepRecord:
        """The tableau (violations, then the peaks of symmetrically bounded inputs, now and in the open
        loop) and, in extra, the trajectories (the memory's rows, shared: no lists per record); the open
        loop's in the first record (and iteration 0's)."""
        sys, v, slack, packed = self.system, self.violations(r), 1e-8 * max(1.0, _scale(r)), self._pack(r)
        found = peaks(sys, r)
        rows = [
            MeasureRow(name, "violation", "dae", value, 0.0, value <= slack, at_least=False)
            for name, value in v.items()
        ]
        rows += peak_rows(sys, found, "peak", slack)
        extra = {
            "lambda": lam,
            "distance": distance,
            "k_minus_s": k_to_s,
            "violations": v,
            "peaks": found,
            "t": self._times,
            "x": packed.x,
            "u": packed.u,
        }
        if self.open_loop is not None:
            initial = peaks(sys, self.open_loop)
            rows += peak_rows(sys, initial, "open-loop peak", slack)
            if i <= 1:
                extra["open_loop"] = {
                    "zero_inputs": list(sys.open_loop),
                    "peaks": initial,
                    "x": self._open_rows.x,
                    "u": self._open_rows.u,
                }
        return StepRecord(
            i,
            status,
            {},
            tuple(rows),
            objective=distance,
            step_size=lam,
            counters={"projections": 0 if k_to_s is None else 1},
            reason=reason,
            extra=extra,
        )

    def _pack(self, t: Trajectory) -> Iterate:
        """The iterate as the memory keeps it (tuples, made once per trajectory, with its arrays
        for the next step).  A non-finite iterate is an error (it could not be stored)."""
        if not (np.all(np.isfinite(t.x)) and np.all(np.isfinite(t.u))):
            raise EngineError("projection: the iterate overflows (the system's scales are beyond floating point)")
        return t.packed

    def _unpack(self, r: Iterate) -> Trajectory:
        if isinstance(r.source, Trajectory):
            return r.source
        sys = self.system
        x, u = np.array(r.x, dtype=float), np.array(r.u, dtype=float)
        if x.shape != (sys.steps + 1, sys.n) or u.shape != (sys.steps + 1, sys.m):
            raise EngineError(
                f"projection memory.r: expected {sys.steps + 1} rows of {sys.n} states and of "
                f"{sys.m} inputs, got x {x.shape} and u {u.shape}"
            )
        return Trajectory(x, u)


def _scale(t: Trajectory) -> float:
    return float(max(np.abs(t.x).max(initial=0), np.abs(t.u).max(initial=0)))

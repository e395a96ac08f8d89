"""`projection`: sequential projection with extrapolation (report 004, Theorem 2).

K1 = the boxes on u and x, K2 = the dynamics with the algebraic equations.
r_1 = P_K2(0) (the LQ solution with zero reference); one `step`:
    k_i = P_K1(r_i)  (clipping: exact for diagonal Q, R),
    s_i = P_K2(k_i)  (Riccati tracking, `lq.py`),
    lambda_i = ||k_i - r_i||^2 / ||s_i - r_i||^2   (>= 1),
    r_{i+1} = r_i + lambda_i (s_i - r_i).
Reset rule (the reactor example): lambda = 1 whenever the product of the
lambdas since the last reset exceeds `reset_product`.  The report also sets
lambda = 1 on its final iteration "for accuracy"; here the answer is the
last r (in K2 exactly) and convergence asks the bounds to hold to the
tolerance as well, which serves the same end.
`extrapolation = False` gives lambda = 1 always (Theorem 1).  Converged
when ||k_i - r_i|| <= tolerance ||r_i||; when the distance stops falling
(the sets are disjoint) the status is infeasible, with the distance and the
bounds that bind.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..algorithm import MeasureRow, State, Status, StepRecord
from ..errors import EngineError
from ..problem import Problem
from .lq import Projector, Trajectory, norm
from .system import DaeSystem, dae_system

STALL_WINDOW = 6


@dataclass(frozen=True)
class ProjectionSettings:
    extrapolation: bool = True
    reset_product: float = 1e3
    tolerance: float = 1e-8
    max_iterations: int = 500
    stall: float = 1e-9          # relative fall of the distance over STALL_WINDOW iterations below this: disjoint

    def __post_init__(self) -> None:
        if not (self.tolerance > 0 and self.reset_product >= 1 and self.max_iterations >= 1):
            raise EngineError("projection: need tolerance > 0, reset_product >= 1, max_iterations >= 1")


class Projection:
    name = "projection"

    def init(self, problem: Problem, settings: ProjectionSettings) -> State:
        if problem.objective is None or problem.objective.kind != "dae":
            raise EngineError("projection: the problem needs an objective of kind 'dae' with the system in its data")
        self.system: DaeSystem = dae_system(problem.objective.data)
        self.settings, self.problem = settings, problem
        self.project = Projector(self.system)
        zero = Trajectory(np.zeros((self.system.steps + 1, self.system.n)),
                          np.zeros((self.system.steps + 1, self.system.m)))
        r = self.project(zero)
        return State(0, (), Status.RUNNING, {"r": _pack(r), "product": 1.0, "distances": []})

    def step(self, state: State) -> tuple[State, StepRecord]:
        s, sys = self.settings, self.system
        r = _unpack(state.memory["r"], sys)
        k = self._clip(r)
        distance = norm(k - r, sys.Q, sys.R)
        scale = max(norm(r, sys.Q, sys.R), 1e-300)
        i = state.iteration + 1
        memory = dict(state.memory)
        history = list(memory["distances"]) + [distance]
        memory["distances"] = history[-STALL_WINDOW - 1:]
        if distance <= s.tolerance * scale and list(self.violations(r).values())[-1] <= s.tolerance * max(1.0, _scale(r)):
            return self._finish(state, memory, r, k, Status.CONVERGED,
                                f"distance between the sets {distance:.3g} <= {s.tolerance:g} x ||r||, every "
                                "bound met to the tolerance", i)
        stalled = len(history) > STALL_WINDOW and history[-STALL_WINDOW - 1] - distance <= s.stall * distance
        if stalled and s.extrapolation and not memory.get("plain"):
            memory.update(plain=True, distances=[distance])   # disjoint sets: lambda = 1 finds the closest pair
            stalled = False
        if stalled:
            return self._finish(state, memory, r, k, Status.INFEASIBLE,
                                f"the sets do not meet: the distance stays at {distance:.6g}; "
                                f"binding: {', '.join(self._binding(r)) or 'none'}", i)
        if i > s.max_iterations:
            return self._finish(state, memory, r, k, Status.ITERATION_LIMIT, f"{s.max_iterations} iterations", i)
        proj = self.project(k)
        denominator = norm(proj - r, sys.Q, sys.R) ** 2
        extrapolate = s.extrapolation and not memory.get("plain") and denominator > 0
        lam = distance ** 2 / denominator if extrapolate else 1.0
        product = memory["product"] * lam
        if product > s.reset_product:
            lam, product = 1.0, 1.0
        memory["product"] = product
        new = r + (proj - r).scaled(lam)
        memory["r"] = _pack(new)
        new_state = State(i, (), Status.RUNNING, memory)
        return new_state, self._record(i, Status.RUNNING, "", new, lam, distance, norm(k - proj, sys.Q, sys.R))

    # -- pieces -----------------------------------------------------------

    def _clip(self, t: Trajectory) -> Trajectory:
        """P_K1: clipping onto the boxes, or the R-norm projection onto the integral hyperplanes."""
        sys = self.system
        if sys.integral is not None:
            C, d = sys.integral, sys.integral_values
            Rinv = np.kron(np.eye(sys.steps + 1), np.linalg.inv(sys.R))
            u = t.u.ravel()
            u = u - Rinv @ C.T @ np.linalg.solve(C @ Rinv @ C.T, C @ u - d)
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
            return {"dynamics": float(np.abs(dyn).max(initial=0)), "algebraic": float(np.abs(alg).max(initial=0)),
                    "hyperplanes": bounds}
        bounds = max(float(np.max(np.maximum(sys.u_lower - t.u, 0), initial=0)),
                     float(np.max(np.maximum(t.u - sys.u_upper, 0), initial=0)),
                     float(np.max(np.maximum(sys.x_lower - t.x, 0), initial=0)),
                     float(np.max(np.maximum(t.x - sys.x_upper, 0), initial=0)))
        return {"dynamics": float(np.abs(dyn).max(initial=0)), "algebraic": float(np.abs(alg).max(initial=0)),
                "bounds": bounds}

    def _finish(self, state: State, memory: dict, r: Trajectory, k: Trajectory, status: Status, reason: str,
                i: int) -> tuple[State, StepRecord]:
        sys = self.system
        record = self._record(i, status, reason, r, None, norm(k - r, sys.Q, sys.R), None)
        return State(i, (), status, memory), record

    def _record(self, i: int, status: Status, reason: str, r: Trajectory, lam: float | None, distance: float,
                k_to_s: float | None) -> StepRecord:
        v = self.violations(r)
        rows = tuple(MeasureRow(name, "violation", "dae", value, 0.0, value <= 1e-8 * max(1.0, _scale(r)))
                     for name, value in v.items())
        extra = {"lambda": lam, "distance": distance, "k_minus_s": k_to_s, "violations": v,
                 "t": self.system.times().tolist(), "x": r.x.tolist(), "u": r.u.tolist()}
        return StepRecord(i, status, {}, rows, objective=distance, step_size=lam,
                          counters={"projections": 1 if lam is not None else 0}, reason=reason, extra=extra)


def _scale(t: Trajectory) -> float:
    return float(max(np.abs(t.x).max(initial=0), np.abs(t.u).max(initial=0)))


def _pack(t: Trajectory) -> dict:
    return {"x": t.x.tolist(), "u": t.u.tolist()}


def _unpack(data: dict, sys: DaeSystem) -> Trajectory:
    return Trajectory(np.array(data["x"], dtype=float).reshape(sys.steps + 1, sys.n),
                      np.array(data["u"], dtype=float).reshape(sys.steps + 1, sys.m))

"""qcg with the problem's linear constraints A x <= b: a penalty on its cost.

CGFM moves every parameter by a factor |1 + scale h| (no sign change) and has
no place for a constraint row, so the cost it minimizes is

    F (1 + PENALTY_WEIGHT sum_r max(0, (A_r x - b_r) / s_r + PENALTY_MARGIN)^2)

with its analytic gradient, s_r the row's size at the start (`row_scale`):
F itself wherever every row is met with the margin.  At an optimum a row holds
back, (A_r x - b_r)/s_r is about lambda_r / (2 PENALTY_WEIGHT) - PENALTY_MARGIN
(lambda_r: F's sensitivity to the row relative to s_r), on the feasible side
for lambda_r below 20, so the design can be adopted as a start.  The record's
F and C are of this cost; FDQ, FDR, FVQ and FVR stay F's own parts.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

import numpy as np
from numpy.typing import NDArray

from engine.design.constraints import PENALTY_WEIGHT, check_start, penalty, row_scale
from engine.design.problem import Problem
from engine.qcg.cost import CostResult
from engine.qcg.setup import CascadeProblem


@dataclass(frozen=True)
class PenalizedCascade(CascadeProblem):
    """The cascade whose cost carries the constraints' penalty (rows over ``names``)."""

    A: NDArray[np.float64] | None = None
    b: NDArray[np.float64] | None = None
    scale: NDArray[np.float64] | None = None

    def cost(self, params: Mapping[str, float], gradient: bool = True) -> CostResult:
        """F times (1 + weight x the squared relative violations), with its gradient."""
        result = super().cost(params, gradient)
        x = np.array([float(params[name]) for name in self.names])
        value, slope = penalty(self.A, self.b, self.scale, x)
        if value == 0.0:
            return result
        factor = 1.0 + PENALTY_WEIGHT * value
        grad = None
        if result.gradient is not None:
            grad = {name: g * factor for name, g in result.gradient.items()}
            for name, d in zip(self.names, slope):
                grad[name] = grad.get(name, 0.0) + result.F * PENALTY_WEIGHT * d
        return replace(result, F=result.F * factor, gradient=grad)


def penalized(made: CascadeProblem, problem: Problem) -> CascadeProblem:
    """``made`` itself without constraints, else the cascade with their penalty (a start
    that does not meet them is refused, naming the constraint)."""
    A, b = problem.linear_constraints
    if not b.size:
        return made
    check_start(problem, problem.vector(), "qcg")
    scale = row_scale(A, b, problem.vector())
    return PenalizedCascade(
        *(getattr(made, f.name) for f in fields(CascadeProblem)), A=np.array(A), b=np.array(b), scale=scale
    )

"""The cost as the optimizers see it: b -> F (and dF/db), counted.

Every call of the cost formula is counted (`Counter`): a step reports how many
evaluations it made and how many of them included the gradient.  `Evaluation`
is what a step keeps of its last one (memory), so the next step starts from it
and a record is made from it, with no evaluation of its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.qcg.cost import CostResult
from engine.qcg.setup import CascadeProblem
from engine.stepping.memory_fields import Fields, jsonable

PARTS = ("FDQ", "FDR", "FVQ", "FVR")
SQUARES = ("x1", "x1_rate", "u", "u_rate")


@dataclass(frozen=True)
class Evaluation:
    """The cost at ``at``: F, dF/db, the parts, the unit-weight integrals and the
    number of refined intervals (what a record shows)."""

    at: tuple[float, ...]
    f: float
    gradient: tuple[float, ...]
    parts: tuple[float, ...]
    squares: tuple[float, ...]
    refined: int

    @classmethod
    def of(cls, b: NDArray, result: CostResult, names: list[str]) -> Self:
        """From a `CostResult` computed with the gradient."""
        return cls(
            tuple(b.tolist()),
            result.F,
            tuple(result.gradient[n] for n in names),
            tuple(result.parts[k] for k in PARTS),
            tuple(result.squares[k] for k in SQUARES),
            result.refined_intervals,
        )

    @property
    def g(self) -> NDArray:
        return np.array(self.gradient)

    def to_json(self) -> dict:
        """Plain JSON types (non-finite parts and squares as strings)."""
        return jsonable(
            {
                "at": self.at,
                "f": self.f,
                "gradient": self.gradient,
                "parts": self.parts,
                "squares": self.squares,
                "refined": self.refined,
            }
        )

    @classmethod
    def from_json(cls, fields: Fields, n: int) -> Self:
        """Read back `to_json`'s data for n parameters (errors name the field)."""
        return cls(
            fields.numbers("at", n),
            fields.number("f"),
            fields.numbers("gradient", n),
            fields.numbers("parts", len(PARTS), finite=False),
            fields.numbers("squares", len(SQUARES), finite=False),
            fields.integer("refined"),
        )


class Counter:
    """F and dF/db at b for one step, counting every evaluation."""

    def __init__(self, cascade: CascadeProblem, problem: Problem, names: list[str]):
        self.cascade, self.problem, self.names = cascade, problem, names
        self.evaluations = self.gradients = 0

    def value(self, b: NDArray) -> float:
        """F alone (a trial); a cost that overflows is +inf, no improvement."""
        self.evaluations += 1
        f = self.cascade.cost(self.problem.condition_values(0, b), gradient=False).F
        return f if np.isfinite(f) else np.inf

    def full(self, b: NDArray) -> Evaluation:
        """F with its gradient; an `EngineError` when they are not finite."""
        found = self.attempt(b)
        if found is None:
            raise EngineError(f"qcg: the cost or its gradient is not finite at {self.problem.named(b)}")
        return found

    def attempt(self, b: NDArray) -> Evaluation | None:
        """F with its gradient, or None when they are not finite."""
        self.evaluations += 1
        self.gradients += 1
        result = self.cascade.cost(self.problem.condition_values(0, b), gradient=True)
        g = np.array([result.gradient[n] for n in self.names])
        if not (np.isfinite(result.F) and np.all(np.isfinite(g))):
            return None
        return Evaluation.of(b, result, self.names)


def counted(memory: Any, counter: Counter) -> dict[str, int]:
    """The memory's counters advanced by a step's evaluations."""
    return {
        "knt": memory.knt + counter.evaluations,
        "evaluations": memory.evaluations + counter.evaluations,
        "gradients": memory.gradients + counter.gradients,
    }

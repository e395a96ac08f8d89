"""The open loop's value and sensitivities at slp's rows' frequencies, for their analytic partials
(`engine.slp.partials`, `engine.slp.peaks`): one batched evaluation per condition and loop break
(a row is read at its target's break, `engine.slp.measures.rows_by_break`), GH, dGH/dx and
dGH/domega at each row's frequency, and the row's partials added into the Jacobian's columns."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.design.problem import Problem
from engine.loop.evaluator import LoopEvaluator
from engine.loop.responses import Response, open_loop
from engine.slp.measures import Spec, rows_by_break


@dataclass(frozen=True)
class LoopSensitivities:
    """One condition's loop broken at one signal, at its rows' frequencies: ``response`` (GH and
    dGH/dx per parameter), ``slope`` (dGH/domega) and each parameter's Jacobian column (None: held)."""

    response: Response
    slope: NDArray[np.complex128]
    columns: list[int | None]

    def at(self, r: int) -> tuple[complex, NDArray, complex]:
        """(GH, dGH/dx, dGH/domega) at the group's ``r``-th frequency."""
        sensitivity = self.response.sensitivity
        gh_x = sensitivity[r] if sensitivity is not None else np.zeros(0)
        return complex(self.response.value[r]), gh_x, complex(self.slope[r])

    def add(self, J: NDArray, i: int, row: NDArray) -> None:
        """Row ``i`` of the Jacobian gains d(measure)/d(parameters) in the free columns."""
        for k, slot in enumerate(self.columns):
            if slot is not None:
                J[i, slot] += row[k]


def loop_sensitivities(
    problem: Problem, x: NDArray, specs: Sequence[Spec], frequencies: NDArray, rows: Sequence[int]
) -> Iterator[tuple[int, str, list[int], LoopSensitivities]]:
    """(condition, break, its rows among ``rows``, the loop's sensitivities there) for each condition with
    an exact loop and each break its rows are read at."""
    for c, condition in enumerate(problem.conditions):
        mine = [i for i in rows if specs[i].condition == c]
        if not mine or not condition.network.exact:
            continue
        params = problem.condition_values(c, x)
        for at, group in rows_by_break(condition, specs, mine).items():
            w = np.array([frequencies[i] for i in group])
            response = open_loop(condition.network, at, w, params, check=False)
            slope = LoopEvaluator(condition.network, at, params)(w)[1]
            columns = [problem.slot_index.get((name, c)) for name in response.parameters]
            yield c, at, group, LoopSensitivities(response, slope, columns)

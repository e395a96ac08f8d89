"""slp's time rows (`engine.slp.measures`: step measures and the peak response) and the
closed-loop stability abscissa of many samples of one problem at once: each sample's closed
loop realized as the per-loop path realizes it (`engine.loop.design.closed_loop_realization`;
all at once when the network allows, `engine.loop.batch_realization`), the realizations stacked, every sample's response to a target's profile simulated in one
recursion (`engine.closed_loop.batch_time`) and read by the per-loop path's own rules
(`engine.slp.measures.response_value`); the abscissa from one batched eigenvalue call on
the stacked closed-loop matrices (each the per-loop path's own matrix).

Continuous loops only (a loop in z steps its samples in z: per loop).  A sample whose
realization fails, or whose realization is not of the study's shape, gets no values (the
per-loop path takes it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.batch_time import batch_simulate
from engine.closed_loop.time_response import Segment
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.batch_realization import batch_closed_loop
from engine.loop.design import closed_loop_realization
from engine.loop.realization import StateSpace
from engine.slp.measures import Spec, response_times, response_value

# the time rows read from a simulated response (a mean square solves a Lyapunov equation: per loop)
BATCH_TIME_KINDS = frozenset(
    ("peak_response", "overshoot_percent", "settling_time", "rise_time", "peak_time", "steady_state_error")
)


def batch_time_rows(
    problem: Problem, specs: Sequence[Spec], xs: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Per sample (rows of the free vectors ``xs``): the values of ``specs``' time rows and
    stability rows of conditions with time rows (NaN in the other columns), and whether the
    sample has them all (else the per-loop path takes it)."""
    values = np.full((xs.shape[0], len(specs)), np.nan)
    ok = np.ones(xs.shape[0], dtype=bool)
    for c in sorted({s.condition for s in specs if s.kind in BATCH_TIME_KINDS}):
        rows = [
            i for i, s in enumerate(specs) if s.condition == c and s.kind in (*BATCH_TIME_KINDS, "stability_abscissa")
        ]
        ok &= _condition_rows(problem, c, [specs[i] for i in rows], xs, values, rows)
    return values, ok


def _condition_rows(
    problem: Problem, c: int, specs: list[Spec], xs: NDArray, values: NDArray, rows: list[int]
) -> NDArray[np.bool_]:
    """Condition ``c``'s rows of every sample written to ``values``' columns ``rows``; which samples have them."""
    realized = _realizations(problem, c, xs)
    shape = next((ss.A.shape for ss in realized if ss is not None), None)
    ok = np.array([ss is not None and ss.A.shape == shape and np.isfinite(ss.A).all() for ss in realized])
    if shape is None or not ok.any():
        return ok
    mine = np.flatnonzero(ok)
    loops = [realized[k] for k in mine]
    A = np.array([ss.A for ss in loops])
    for spec, column in zip(specs, rows):
        if spec.kind == "stability_abscissa":
            values[mine, column] = _abscissa(A)
            continue
        response = problem.targets[spec.target].response
        first = loops[0]
        if response.input not in first.inputs or response.output not in first.outputs:
            return np.zeros_like(ok)  # the per-loop path says what is wrong
        k, j = first.inputs.index(response.input), first.outputs.index(response.output)
        t = response_times(response, None)
        segments = [Segment(*p) for p in response.profile]
        B, C = np.array([ss.B[:, k] for ss in loops]), np.array([ss.C[j] for ss in loops])
        D = np.array([ss.D[j, k] for ss in loops])
        with np.errstate(all="ignore"):
            y = batch_simulate(A, B, C, D, t, segments)
        for row, (sample, ss) in enumerate(zip(mine.tolist(), loops)):
            values[sample, column] = response_value(spec, response, ss, t, y[row])
    return ok


def _realizations(problem: Problem, c: int, xs: NDArray) -> list[StateSpace | None]:
    """Condition ``c``'s closed loop of every sample: realized for all at once when the network
    allows it (`engine.loop.batch_realization`: the same matrices), else one by one."""
    condition = problem.conditions[c]
    values = [problem.condition_values(c, x) for x in xs]
    columns = {name: np.array([v[name] for v in values]) for name in values[0]} if values else {}
    stacked = batch_closed_loop(condition.network, condition.break_at, columns) if columns else None
    if stacked is None:
        return [_realized(problem, c, x) for x in xs]
    return [
        StateSpace(A, B, C, D, stacked.inputs, stacked.outputs)
        for A, B, C, D in zip(stacked.A, stacked.B, stacked.C, stacked.D)
    ]


def _realized(problem: Problem, c: int, x: NDArray) -> StateSpace | None:
    """Condition ``c``'s closed loop at the free values ``x``, as the per-loop path realizes it; None when that fails."""
    condition = problem.conditions[c]
    try:
        return closed_loop_realization(condition.network, condition.break_at, problem.condition_values(c, x))
    except (EngineError, ValueError, np.linalg.LinAlgError):
        return None


def _abscissa(A: NDArray) -> NDArray[np.float64]:
    """-max Re of every stacked matrix's eigenvalues (`engine.design.tableau.stability_abscissa`; inf with no states)."""
    if A.shape[1] == 0:
        return np.full(A.shape[0], math.inf)
    return -np.max(np.linalg.eigvals(A).real, axis=1)

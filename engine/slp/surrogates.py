"""slp's surrogate rows (`engine.design.measure_kinds.absence_role`): a requirement the loop
cannot be judged on because it lacks the feature, steered by a level it has.  A crossover
frequency required at omega_d with no crossover in the band is steered by the loop's
20 log10 |GH(j omega_d)| toward 0 dB (up when |GH| < 1 everywhere, down when |GH| > 1
everywhere), its partials by forward differences."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from engine.design.measure_kinds import surrogate_sign
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.slp.measures import Spec, spec_break


def surrogate_frequency(spec: Spec) -> float:
    """The frequency the surrogate reads: the crossover the row asks for."""
    wanted = spec.required if spec.required is not None else spec.desired
    return math.nan if wanted is None else float(wanted)


def loop_level_db(problem: Problem, x: NDArray, spec: Spec) -> float:
    """20 log10 |GH(j omega_d)| of the row's loop (its condition broken at the row's break) at the free
    values ``x`` (NaN where the loop cannot be evaluated there: a frequency outside the grid's reach or
    a sampled loop's Nyquist band)."""
    omega = surrogate_frequency(spec)
    if not (math.isfinite(omega) and omega > 0):
        return math.nan
    condition = problem.conditions[spec.condition]
    try:
        at = spec_break(spec, condition)
        model = loop_model(condition.network, at, np.array([omega]), problem.condition_values(spec.condition, x))
        magnitude = float(np.abs(model.gh[0]))
    except (EngineError, ValueError, ZeroDivisionError, np.linalg.LinAlgError):
        return math.nan
    return 20.0 * math.log10(magnitude) if magnitude > 0 and math.isfinite(magnitude) else math.nan


def surrogate_row(
    problem: Problem, x: NDArray, spec: Spec, value: float, fd_step: float
) -> tuple[float, NDArray[np.float64]] | None:
    """The surrogate's level oriented so that larger is better (sign times the level in dB,
    its requirement 0) and its gradient in the free values; None where it cannot be read."""
    sign = surrogate_sign(value)
    level = loop_level_db(problem, x, spec)
    if not math.isfinite(level):
        return None
    gradient = np.zeros(len(x))
    for i in range(len(x)):
        h = fd_step * max(abs(float(x[i])), 1.0)
        moved = np.array(x, dtype=float)
        moved[i] += h
        shifted = loop_level_db(problem, moved, spec)
        if not math.isfinite(shifted):
            return None
        gradient[i] = (shifted - level) / h
    return sign * level, sign * gradient

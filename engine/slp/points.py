"""slp's verdicts on many points at once, as arrays: each row met or not, the met-measure
counter, the figure of merit and which rows stand at their absence value, for a batch of
samples whose rows' values and frequencies were found elsewhere (`sessions.sweeps.batch_study`),
so that no Python object is made per sample and row until a sample's run is kept.

Each is `engine.slp.algorithm.Slp.point_at`'s and `Slp.row_fields`'s, vectorized over the
samples: a row is met as `engine.slp.measures.Spec.met` says, absent as
`engine.slp.measures.absent_row` says, judged (no term of the figure of merit) when it is
absent and met or has no surrogate (`engine.design.measure_kinds.absence_role`), and the
figure of merit sums the terms row by row in the rows' order (the same additions, so the
same bits).  The load-relief objective has no batch form: None.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.design.measure_kinds import ABSENT, NO_CROSSOVER, SURROGATES
from engine.design.problem import FREQUENCY_MEASURES
from engine.slp.measures import Spec


@dataclass(frozen=True)
class Points:
    """Per sample (rows) and measure row (columns): met, at its absence value; per sample: the
    counter of met requirements and the figure of merit."""

    met: NDArray[np.bool_]
    absent: NDArray[np.bool_]
    counter: NDArray[np.int64]
    merit: NDArray[np.float64]


def points(specs: Sequence[Spec], objective: str, values: NDArray, frequencies: NDArray) -> Points | None:
    """The verdicts on the points whose rows (``specs``) have these values and frequencies
    (samples, rows); None for the load-relief objective (module docstring)."""
    if objective == "load_relief":
        return None
    count = values.shape[0]
    met = (
        np.column_stack([_met(spec, values[:, i]) for i, spec in enumerate(specs)])
        if specs
        else np.zeros((count, 0), bool)
    )
    absent = (
        np.column_stack([_absent(spec, values[:, i], frequencies[:, i]) for i, spec in enumerate(specs)])
        if specs
        else np.zeros((count, 0), bool)
    )
    counter = np.zeros(count, dtype=np.int64)
    merit = np.zeros(count)
    for i, spec in enumerate(specs):
        if spec.required is not None:
            counter += met[:, i]
        if spec.desired is None or spec.weight == 0:
            continue
        judged = absent[:, i] & (met[:, i] | (spec.kind not in SURROGATES))
        v = values[:, i]
        term = spec.weight * spec.scale * np.minimum(spec.sign * v, spec.sign * spec.desired)
        merit = np.where(judged | np.isnan(v), merit, merit + term)
    return Points(met, absent, counter, merit)


def _met(spec: Spec, v: NDArray) -> NDArray[np.bool_]:
    """`Spec.met` of every value."""
    if spec.required is None:
        return np.ones(v.size, dtype=bool)
    if spec.kind == "stability_abscissa":
        return v > spec.required  # (a NaN is not greater: never met)
    return v >= spec.required if spec.at_least else v <= spec.required


def _absent(spec: Spec, v: NDArray, f: NDArray) -> NDArray[np.bool_]:
    """`engine.slp.measures.absent_row` of every value and frequency."""
    if spec.kind not in FREQUENCY_MEASURES:
        return np.zeros(v.size, dtype=bool)
    if spec.kind == "crossover_frequency":
        stands = np.isin(v, [value for value, _ in NO_CROSSOVER.values()])
    else:
        found = ABSENT.get(spec.kind)
        stands = np.zeros(v.size, dtype=bool) if found is None else v == found[0]
    return np.isnan(f) & stands

"""A penalty sweep (report 001, Figure 4): optimize for each value of one
penalty (q2, r1 or r2) and collect the averaged-square output, output rate,
control and control rate.

Continuation: the design is first optimized at the session's own penalty
value from the session's start, then the sweep walks outward from there
(up through the larger values, down through the smaller ones), each run
starting at its neighbour's optimum, which saves evaluations.  (Started cold
at q2 = 0 from b = (10, 10000) on the inlet, CGFM once stopped at a jump of
the listing's refinement, b21 = 7011; with the continuous cost it reaches
b = (111.4, 81.9), docs/algorithms/qcg.md.)"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.qcg.algorithm import Qcg, QcgSettings
from engine.stepping.driver import iterate

PENALTIES = ("q1", "q2", "r1", "r2")


@dataclass(frozen=True)
class TradeoffPoint:
    """One optimized design of the sweep."""

    penalty: float
    parameters: dict[str, float]
    status: str
    cost: float
    averaged_squares: dict[str, float]
    evaluations: int


def penalty_sweep(
    problem: Problem, settings: QcgSettings, penalty: str, values: Sequence[float], max_steps: int = 1000
) -> list[TradeoffPoint]:
    """Optimized designs at every penalty value, sorted by value (see the module docstring)."""
    if penalty not in PENALTIES:
        raise EngineError(f"tradeoff: penalty must be one of {', '.join(PENALTIES)}, not {penalty!r}")
    if problem.objective is None:
        raise EngineError("tradeoff: the problem has no objective")
    home = float(problem.objective.options.get(penalty, 1.0 if penalty == "q1" else 0.0))
    _, x_home = _optimize(problem, settings, penalty, home, max_steps)
    ordered = sorted(set(float(v) for v in values))
    points: dict[float, TradeoffPoint] = {}
    for walk in ([v for v in ordered if v >= home], [v for v in reversed(ordered) if v < home]):
        x = x_home
        for value in walk:
            point, x = _optimize(problem.with_vector(x), settings, penalty, value, max_steps)
            points[value] = point
    return [points[v] for v in ordered]


def _optimize(
    problem: Problem, settings: QcgSettings, penalty: str, value: float, max_steps: int
) -> tuple[TradeoffPoint, tuple[float, ...]]:
    objective = replace(problem.objective, options=dict(problem.objective.options, **{penalty: value}))
    runs = list(iterate(Qcg.bind(replace(problem, objective=objective), settings), max_iter=max_steps))
    if not runs:
        raise EngineError("tradeoff: the search made no step")
    state, record = runs[-1]
    point = TradeoffPoint(
        value,
        dict(record.parameters),
        record.status.value,
        float(record.objective),
        dict(record.extra["averaged_squares"]),
        int(record.counters["evaluations"]),
    )
    return point, state.x

"""The cascade of report 001's Figure 2 read from a `Problem`.

The first condition's network must have blocks named G1, G2, Ga (actuator
times transducer gain K) and H1 and/or H2 (the controllers, functions of the
free parameters); G1, G2 and Ga must not depend on parameters.  The
objective is ``quadratic_cost`` with options q1, q2, r1, r2, averaging_time,
disturbance_amplitude, disturbance_pole (d(t) = A exp(-a t)), rsnat,
subdivisions, normalizing_gain, and tables ``noise_psd`` (magnitude = Phi_v)
and optionally ``disturbance_psd`` (then used in place of |d|^2 / T).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from engine.design.measure_kinds import TargetUse
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.model.blocks import Transfer
from engine.qcg.cost import Cascade, CostResult, Weights, exponential_disturbance, frequency_response, quadratic_cost

TARGETS = TargetUse(reads=False, refusal="is not read by qcg (it minimizes its quadratic cost and reads no targets)")
OPTIONS = (
    "q1",
    "q2",
    "r1",
    "r2",
    "averaging_time",
    "disturbance_amplitude",
    "disturbance_pole",
    "rsnat",
    "subdivisions",
    "normalizing_gain",
)


@dataclass(frozen=True)
class CascadeProblem:
    """Everything the cost needs, evaluated once on the grid."""

    cascade: Cascade
    h1: Transfer | None
    h2: Transfer | None
    weights: Weights
    names: tuple[str, ...]
    normalizing_gain: float

    def cost(self, params: Mapping[str, float], gradient: bool = True) -> CostResult:
        """One evaluation of the cost (and its gradient) at the controller parameters."""
        return quadratic_cost(self.cascade, self.h1, self.h2, params, self.weights, gradient, self.names)

    def frequency_response(self, params: Mapping[str, float]) -> list[dict[str, float]]:
        with np.errstate(all="ignore"):
            return frequency_response(self.cascade, self.h1, self.h2, params, self.normalizing_gain)


def cascade_problem(problem: Problem) -> CascadeProblem:
    """The cascade of the problem's first condition, or an `EngineError` saying what is missing."""
    with np.errstate(all="ignore"):
        made = _cascade_problem(problem)
    data = made.cascade
    if not all(np.all(np.isfinite(a)) for a in (data.g1, data.g1g2, data.ga, data.noise_psd, data.disturbance)):
        raise EngineError("qcg: the plant or the noise and disturbance weights are not finite on the grid")
    from engine.qcg.penalty import penalized  # the linear constraints' penalty (penalty.py builds on this module)

    return penalized(made, problem)


def _cascade_problem(problem: Problem) -> CascadeProblem:
    objective = problem.objective
    if objective is None or objective.kind != "quadratic_cost":
        raise EngineError("qcg: the problem needs an objective of kind 'quadratic_cost'")
    TARGETS.check_targets("qcg", problem.targets)
    unknown = sorted(set(objective.options) - set(OPTIONS))
    if unknown:
        raise EngineError(f"qcg: unknown objective option(s) {', '.join(unknown)}; options are {', '.join(OPTIONS)}")
    if not problem.conditions:
        raise EngineError("qcg: the problem needs a flight condition (the cascade of report 001, Figure 2)")
    network = problem.conditions[0].network
    if network.sample_time is not None:
        raise EngineError(
            "qcg: report 001's cost integrates a continuous loop's PSDs over frequency; a condition in z is not "
            "one (design it with slp or cip, or give qcg the continuous plant)"
        )
    blocks = {e.label: e.transfer for e in network.entries}
    missing = [name for name in ("G1", "G2", "Ga") if name not in blocks]
    if missing or not ({"H1", "H2"} & set(blocks)):
        raise EngineError(
            "qcg: the plant needs blocks named G1, G2, Ga and H1 and/or H2 (report 001, Figure 2); "
            f"missing {', '.join(missing) or 'H1/H2'}"
        )
    w = problem.grid.omega
    fixed = {}
    for name in ("G1", "G2", "Ga"):
        if blocks[name].parameters:
            raise EngineError(f"qcg: block {name} depends on parameters; only H1 and H2 are tuned")
        fixed[name] = np.broadcast_to(blocks[name].evaluate(1j * w, {}).value, w.shape).astype(complex)
    option = _options(objective.options)
    tables = objective.tables
    if "noise_psd" in tables:
        noise = np.abs(tables["noise_psd"].interpolate(w))
    else:
        noise = np.zeros(w.size)
    if "disturbance_psd" in tables:
        disturbance = np.abs(tables["disturbance_psd"].interpolate(w))
    else:
        disturbance = exponential_disturbance(
            w,
            option.get("disturbance_amplitude", 0.0),
            option.get("disturbance_pole", 1.0),
            option.get("averaging_time", 1.0),
        )
    exact = _exact_plant(blocks) if all(blocks[name].exact for name in ("G1", "G2", "Ga")) else None
    cascade = Cascade(w, fixed["G1"], fixed["G1"] * fixed["G2"], fixed["Ga"], noise, disturbance, exact)
    weights = Weights(
        option.get("q1", 1.0),
        option.get("q2", 0.0),
        option.get("r1", 0.0),
        option.get("r2", 0.0),
        option.get("rsnat", 0.5),
        int(option.get("subdivisions", 3)),
    )
    names = tuple(problem.parameters[i].name for i, _ in problem.free_slots())
    return CascadeProblem(
        cascade, blocks.get("H1"), blocks.get("H2"), weights, names, option.get("normalizing_gain", 1.0)
    )


# option -> (least, greatest, whether the least is excluded)
RANGES = {
    "averaging_time": (0.0, 1e300, True),
    "rsnat": (0.0, 1e300, False),
    "subdivisions": (1, 100, False),
    "q1": (0.0, 1e300, False),
    "q2": (0.0, 1e300, False),
    "r1": (0.0, 1e300, False),
    "r2": (0.0, 1e300, False),
}


def _options(options: Mapping[str, object]) -> dict[str, float]:
    """The objective's options as numbers in their ranges, or an `EngineError` naming the option."""
    out = {}
    for name, value in options.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
            raise EngineError(f"qcg: objective option {name} must be a finite number, not {str(value)[:40]!r}")
        low, high, strict = RANGES.get(name, (-np.inf, np.inf, False))
        if not (low < value if strict else low <= value) or value > high:
            raise EngineError(
                f"qcg: objective option {name} = {value!r} is outside {'(' if strict else '['}{low:g}, {high:g}]"
            )
        out[name] = float(value)
    if out.get("normalizing_gain", 1.0) == 0:
        raise EngineError("qcg: objective option normalizing_gain must not be 0")
    return out


def _exact_plant(blocks: Mapping[str, Transfer]):
    """G1, G1G2 and Ga at any frequencies (plants in closed form)."""

    def evaluate(omega: np.ndarray):
        g1, g2, ga = (
            np.broadcast_to(blocks[n].evaluate(1j * omega, {}).value, omega.shape).astype(complex)
            for n in ("G1", "G2", "Ga")
        )
        return g1, g1 * g2, ga

    return evaluate

"""The algorithms' figures: a `cip` iteration (and its scaling with points and
channels), the qcg sample (the slot for its optimizers), the projection
examples (and their scaling with N), an `slp` major iteration."""

from __future__ import annotations

import statistics
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

from engine.model.network import Block, Junction, block_diagram
from tests.bench.common import judged, samples, scaling, timed

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
CIP_TARGET_S = 0.001


def cip_problem(every: int = 1, channels: int = 2):
    """The launch vehicle's attitude, rate (and acceleration) channels on every
    ``every``-th point of its 999, 4 second-order sub-compensators each
    (2 channels: 34 free coefficients)."""
    from engine.design.problem import BandValue, Condition, Grid, Parameter, Problem, Target
    from engine.model.blocks import FrequencyTable, TabulatedTransfer, polynomial_transfer
    from sessions.examples.launch_vehicles import E1_1, SINGLE_GRID, single_channel

    f = SINGLE_GRID[::every]
    attitude, jw = single_channel(f), 2j * np.pi * f
    responses = dict(
        list({"att": attitude, "rate": jw * attitude * 0.2, "acc": jw * jw * attitude * 0.04}.items())[:channels]
    )
    factors = E1_1 + [([400.0, 2.0, 1.0], [400.0, 8.0, 1.0])]
    blocks, params, outputs = [], [], []
    for ch, response in responses.items():
        blocks.append(
            Block(f"{ch}.response", "e", f"{ch}.0", TabulatedTransfer(FrequencyTable(f * 2 * np.pi, response)), ch)
        )
        for k, (num, den) in enumerate(factors, start=1):
            names = ([f"{ch}{k}x{i}" for i in range(len(num))], [f"{ch}{k}y{i}" for i in range(len(den))])
            for side, values in zip(names, (num, den)):
                params += [
                    Parameter(n, float(v), minimum=0.0, free=i > 0 or (k == 1 and n.endswith("y0")))
                    for i, (n, v) in enumerate(zip(side, values))
                ]
            blocks.append(
                Block(f"{ch}.{k}", f"{ch}.{k - 1}", f"{ch}.{k}", polynomial_transfer(*names, "ascending"), ch)
            )
        outputs.append(f"{ch}.{len(factors)}")
    junctions = [
        Junction("sum", "c", tuple((1.0, o) for o in outputs)),
        Junction("err", "e", ((1.0, "r"), (-1.0, "c"))),
    ]
    net = block_diagram(blocks, junctions, ["r"])
    every_w = (0.0, np.inf)
    targets = (
        Target("gain_margin", (BandValue(*every_w, 1.5),), detect_high=2 * np.pi * 0.1),
        Target("stability_margin", (BandValue(*every_w, 0.6),)),
        Target("attenuation_margin", (BandValue(*every_w, 0.2),), detect_low=2 * np.pi * 2.1),
    )
    return Problem((Condition("flight", net, "e"),), tuple(params), targets, Grid(f * 2 * np.pi))


def cip_iterations(problem, runs: int) -> tuple[list[float], list[int]]:
    """Wall times of `cip` steps over ``runs`` runs of consecutive iterations
    from the start (as a user steps), and the trial moves of each step."""
    from engine.cip import Cip, CipSettings

    cip, times, trials = Cip.bind(problem, CipSettings(mode="tifr", max_step=0.05)), [], []
    for _ in range(runs):
        state = cip.init()
        for _ in range(40):
            start = time.perf_counter()
            state, record = cip.step(state)
            times.append(time.perf_counter() - start)
            trials.append(record.counters.get("trials", 0))
            if state.status.finished:
                break
    return times, trials


def cip_figures(repeat: int) -> dict:
    """One `cip` iteration (999 points, 2 channels, 34 free coefficients;
    target 1 ms), and its scaling with points (2 channels) and channels (999 points)."""
    runs = max(repeat // 6, 3)
    problem = cip_problem()
    times, trials = cip_iterations(problem, runs)
    out = {
        "iteration": timed(
            statistics.median(times),
            CIP_TARGET_S,
            frequencies=problem.grid.omega.size,
            channels=2,
            free_coefficients=len(problem.free_slots()),
            iterations_timed=len(times),
            mean_trials=statistics.mean(trials),
            report_univac_1106_s=0.9,
        )
    }
    sizes, medians = [], []
    for every in (4, 2, 1):
        p = cip_problem(every)
        sizes.append(p.grid.omega.size)
        medians.append(statistics.median(cip_iterations(p, max(runs // 2, 2))[0]))
    out["scaling_vs_points"] = scaling("frequencies", sizes, medians)
    channel_medians = [statistics.median(cip_iterations(cip_problem(1, c), max(runs // 2, 2))[0]) for c in (1, 2, 3)]
    out["scaling_vs_channels"] = scaling("channels", [1, 2, 3], channel_medians)
    return out


# slot for qcg's owner: ratio targets of the qcg figures, name -> (target, "min_ratio" or "max_ratio"),
# e.g. {"time_qcg_lbfgsb_over_cgfm": (1.0, "max_ratio")}; the names are those of `qcg_figures`' "ratios"
QCG_TARGETS: dict[str, tuple[float, str]] = {}


def qcg_figures(repeat: int) -> dict:
    """Report 001's sample (`seidel_inlet_pi.json`) to convergence: CGFM, qcg's
    ``optimizer="lbfgsb"`` when qcg has that setting, scipy L-BFGS-B with the
    analytic gradient (the reference) and scipy BFGS with a numerical gradient,
    same cost, same start, interleaved (all parameters of the sample are free)."""
    from scipy.optimize import minimize

    from engine.qcg import Qcg, QcgSettings
    from engine.qcg.setup import cascade_problem
    from engine.stepping.driver import iterate
    from sessions.store import load_session

    problem = load_session(EXAMPLES / "seidel_inlet_pi.json").problem
    cascade, names = cascade_problem(problem), [p.name for p in problem.parameters]

    def qcg(**settings):
        return lambda i=0: list(iterate(Qcg.bind(problem, QcgSettings(**settings)), max_iter=1000))[-1][1]

    def cost(b):
        result = cascade.cost(dict(zip(names, b)), gradient=True)
        return result.F, np.array([result.gradient[n] for n in names])

    runs = {
        "cgfm": qcg(),
        "scipy_lbfgsb_analytic_gradient": lambda i=0: minimize(  # scipy's defaults stop at
            cost,
            problem.vector(),
            jac=True,
            method="L-BFGS-B",  # F = 0.343 on this badly scaled problem
            options={"ftol": 1e-15, "gtol": 1e-12},
        ),
        "scipy_bfgs_numerical_gradient": lambda i=0: minimize(
            lambda b: cascade.cost(dict(zip(names, b)), gradient=False).F,
            problem.vector(),
            method="BFGS",
            options={"gtol": 1e-9},
        ),
    }
    has_lbfgsb = "optimizer" in {f.name for f in fields(QcgSettings)}
    if has_lbfgsb:
        runs["qcg_lbfgsb"] = qcg(optimizer="lbfgsb")
    times = samples(list(runs.values()), max(repeat // 3, 3))
    out: dict = {"qcg_has_lbfgsb": has_lbfgsb}
    for (name, run), t in zip(runs.items(), times):
        result = run()
        if name.startswith("scipy"):
            out[name] = {
                "median_s": statistics.median(t),
                "F": float(result.fun),
                "evaluations": int(result.nfev),
                "success": bool(result.success),
            }
        else:
            out[name] = {
                "median_s": statistics.median(t),
                "F": result.extra["F"],
                "evaluations": result.counters["KNT"],
            }
    ratios = {
        f"time_{other}_over_cgfm": statistics.median([a / b for a, b in zip(t, times[0])])
        for other, t in zip(list(runs)[1:], times[1:])
    }
    out["ratios"] = {
        name: {"ratio": r, **(judged(r, *QCG_TARGETS[name]) if name in QCG_TARGETS else {})}
        for name, r in ratios.items()
    }
    return out


PROJECTION_CASES = {  # name: (bundled session, target s at N = 20, at N = 2000)
    "projection_integrator": ("projection_integrator.json", 0.050, 0.100),
    "projection_reactor": ("projection_reactor.json", 0.050, 0.300),
}
PROJECTION_STEPS = (20, 200, 2000)


def projection_figures(repeat: int) -> dict:
    """Report 004's examples to convergence with their sessions' settings at
    N = 20, 200, 2000 (interleaved), with targets at 20 and 2000 and the
    fitted exponent of time against N."""
    from engine.projection import Projection
    from engine.stepping.driver import iterate
    from engine.stepping.registry import make_settings
    from sessions.store import load_session

    runs = []
    for file, _, _ in PROJECTION_CASES.values():
        session = load_session(EXAMPLES / file)
        settings = make_settings("projection", session.model.algorithm.settings)
        for steps in PROJECTION_STEPS:
            objective = replace(session.problem.objective, data=dict(session.problem.objective.data, steps=steps))
            problem = replace(session.problem, objective=objective)
            runs.append(
                lambda i=0, p=problem, s=settings: list(iterate(Projection.bind(p, s), max_iter=s.max_iterations + 1))
            )
    medians = [statistics.median(t) for t in samples(runs, repeat)]
    out, k = {}, 0
    for name, (_, target_20, target_2000) in PROJECTION_CASES.items():
        for steps in PROJECTION_STEPS:
            records = [r for _, r in runs[k]()]
            target = {20: target_20, 2000: target_2000}.get(steps)
            key = name if steps == 20 else f"{name}_{steps}"
            out[key] = timed(medians[k], target, steps=steps, iterations=len(records), status=records[-1].status.value)
            k += 1
        out[f"{name}_scaling_vs_N"] = scaling("N", PROJECTION_STEPS, medians[k - len(PROJECTION_STEPS) : k])
    return out


def slp_major_iteration(repeat: int) -> dict:
    """`coebra_launch_vehicle.json` (3 flight conditions, 14 free variables,
    27 measures): the first major iteration from the start (partials, then
    minor-loop trials until the relinearization); target 0.5 s (report 003: 164 s)."""
    from engine.slp import Slp
    from engine.stepping.registry import make_settings
    from sessions.store import load_session

    samples_, trials, session = [], 0, None
    for _ in range(max(repeat // 5, 3)):
        session = load_session(EXAMPLES / "coebra_launch_vehicle.json")  # fresh networks: no cached realization
        settings = make_settings("slp", session.model.algorithm.settings)
        start = time.perf_counter()
        algorithm = Slp.bind(session.problem, settings)
        state = algorithm.init()
        trials = 0
        while state.memory.major == 1 and not state.status.finished:
            state, _ = algorithm.step(state)
            trials += 1
        samples_.append(time.perf_counter() - start)
    return timed(
        statistics.median(samples_),
        0.5,
        minor_trials=trials,
        free_variables=len(session.problem.free_slots()),
        report_cdc_s=164.0,
    )

"""Benchmarks (`make bench`): medians, and ratios against python-control run
in the same process on the same loop.  Writes JSON; prints a summary.

The `cip` problem: two channels tabulated at 999 points, 34 free coefficients;
one iteration timed as a user steps (consecutive iterations from the start).

The loop: 20 second-order sections in series (a 40th-order open loop, lightly
damped modes from zeta = 0.005), 30 free parameters (zeta and omega of 15
sections), unity feedback; 1000 frequencies."""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
import warnings

import control as ct
import numpy as np

from engine.blocks import ExpressionTransfer
from engine.loops import loop_model, open_loop
from engine.margins import margins
from engine.network import Block, Junction, block_diagram

SECTIONS = 20
FREE = 15


def benchmark_loop():
    """(network, params, num, den) of the 40th-order, 30-parameter loop."""
    rng = np.random.default_rng(7)
    blocks, params, previous = [], {}, "e"
    num, den = np.array([1.0]), np.array([1.0])
    for k in range(SECTIONS):
        wp, zp = 10 ** rng.uniform(-0.5, 2), 10 ** rng.uniform(np.log10(0.005), -0.3)
        wz, zz = wp * 10 ** rng.uniform(-0.3, 0.3), 10 ** rng.uniform(np.log10(0.005), -0.3)
        out = "y" if k == SECTIONS - 1 else f"x{k}"
        if k < FREE:
            params[f"z{k}"], params[f"w{k}"] = zp, wp
            den_text = f"(s**2/w{k}**2 + 2*z{k}*s/w{k} + 1)"
        else:
            den_text = f"(s**2/{wp!r}**2 + 2*{zp!r}*s/{wp!r} + 1)"
        gain = 3.0 if k == 0 else 1.0
        text = f"{gain}*(s**2/{wz!r}**2 + 2*{zz!r}*s/{wz!r} + 1)/{den_text}"
        blocks.append(Block(f"S{k}", previous, out, ExpressionTransfer(text)))
        num = np.polymul(num, gain * np.array([1 / wz**2, 2 * zz / wz, 1.0]))
        den = np.polymul(den, np.array([1 / wp**2, 2 * zp / wp, 1.0]))
        previous = out
    net = block_diagram(blocks, [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))], ["r"])
    return net, params, num, den


def cip_problem():
    """2 channels (attitude and rate of the single-channel vehicle), 999 points,
    4 second-order sub-compensators each: 34 free coefficients."""
    from engine.blocks import FrequencyTable, TabulatedTransfer, polynomial_transfer
    from engine.problem import BandValue, Condition, Grid, Parameter, Problem, Target
    from sessions.examples.launch_vehicles import E1_1, SINGLE_GRID, single_channel

    f = SINGLE_GRID
    attitude = single_channel(f)
    responses = {"att": attitude, "rate": 2j * np.pi * f * attitude * 0.2}
    factors = E1_1 + [([400.0, 2.0, 1.0], [400.0, 8.0, 1.0])]
    blocks, params, outputs = [], [], []
    for ch, response in responses.items():
        blocks.append(Block(f"{ch}.response", "e", f"{ch}.0", TabulatedTransfer(FrequencyTable(f * 2 * np.pi, response)),
                            ch))
        for k, (num, den) in enumerate(factors, start=1):
            names = ([f"{ch}{k}x{i}" for i in range(len(num))], [f"{ch}{k}y{i}" for i in range(len(den))])
            for side, values in zip(names, (num, den)):
                params += [Parameter(n, float(v), minimum=0.0, free=i > 0 or (k == 1 and n.endswith("y0")))
                           for i, (n, v) in enumerate(zip(side, values))]
            blocks.append(Block(f"{ch}.{k}", f"{ch}.{k - 1}", f"{ch}.{k}", polynomial_transfer(*names, "ascending"), ch))
        outputs.append(f"{ch}.{len(factors)}")
    junctions = [Junction("sum", "c", tuple((1.0, o) for o in outputs)), Junction("err", "e", ((1.0, "r"), (-1.0, "c")))]
    net = block_diagram(blocks, junctions, ["r"])
    every = (0.0, np.inf)
    targets = (Target("gain_margin", (BandValue(*every, 1.5),), detect_high=2 * np.pi * 0.1),
               Target("stability_margin", (BandValue(*every, 0.6),)),
               Target("attenuation_margin", (BandValue(*every, 0.2),), detect_low=2 * np.pi * 2.1))
    return Problem((Condition("flight", net, "e"),), tuple(params), targets, Grid(f * 2 * np.pi))


def cip_iterations(problem, repeat: int) -> tuple[float, list[int]]:
    """Median wall time of one `cip` step over runs of consecutive iterations
    (as a user steps), and the number of trial moves each step made."""
    from engine.cip import Cip, CipSettings
    cip, times, trials = Cip(), [], []
    for _ in range(max(repeat // 6, 3)):
        state = cip.init(problem, CipSettings(mode="tifr", max_step=0.05))
        for _ in range(40):
            start = time.perf_counter()
            state, record = cip.step(state)
            times.append(time.perf_counter() - start)
            trials.append(record.counters.get("trials", 0))
            if state.status.finished:
                break
    return statistics.median(times), trials


def qcg_comparison(repeat: int) -> dict:
    """Report 001's sample: CGFM to convergence, and scipy BFGS with a numerical
    gradient on the same cost (the listing's F of b), same start, same process."""
    from pathlib import Path

    from scipy.optimize import minimize

    from engine.algorithm import iterate
    from engine.qcg import Qcg, QcgSettings
    from engine.qcg.setup import cascade_problem
    from sessions.store import load_session

    session = load_session(Path(__file__).resolve().parents[2] / "sessions" / "examples" / "seidel_inlet_pi.json")
    problem, cascade = session.problem, cascade_problem(session.problem)
    names = [p.name for p in problem.parameters]

    def cgfm(i=0):
        return list(iterate(Qcg(), problem, QcgSettings(), max_iter=1000))[-1][1]

    def bfgs(i=0):
        def cost(b):
            return cascade.cost(dict(zip(names, b)), gradient=False).F
        return minimize(cost, problem.vector(), method="BFGS", options={"gtol": 1e-9})

    ours, theirs = cgfm(), bfgs()
    t_ours, t_theirs = median_time(cgfm, max(repeat // 3, 3)), median_time(bfgs, max(repeat // 3, 3))
    return {"cgfm": {"median_s": t_ours, "evaluations": ours.counters["KNT"], "F": ours.extra["F"],
                     "b": dict(ours.parameters)},
            "scipy_bfgs_numerical_gradient": {"median_s": t_theirs, "evaluations": int(theirs.nfev),
                                              "F": float(theirs.fun), "b": dict(zip(names, theirs.x.tolist())),
                                              "success": bool(theirs.success)},
            "ratios": {"time_bfgs_over_cgfm": t_theirs / t_ours,
                       "evaluations_bfgs_over_cgfm": theirs.nfev / ours.counters["KNT"]}}


PROJECTION_CASES = {   # name: (bundled session, time steps N, target s)
    "projection_integrator": ("projection_integrator.json", 20, 0.050),
    "projection_integrator_2000": ("projection_integrator.json", 2000, 0.100),
    "projection_reactor": ("projection_reactor.json", 20, 0.050),
    "projection_reactor_2000": ("projection_reactor.json", 2000, 0.300),
}


def projection_runs(repeat: int) -> dict:
    """Report 004's examples (a) and (b) to convergence with their sessions' settings, at the report's
    N = 20 and at N = 2000, timed interleaved (issue 22's targets: 100 ms and 300 ms at N = 2000)."""
    from dataclasses import replace
    from pathlib import Path

    from engine.algorithm import iterate, make_settings
    from engine.projection import Projection
    from sessions.store import load_session
    folder = Path(__file__).resolve().parents[2] / "sessions" / "examples"
    runs = []
    for file, steps, _ in PROJECTION_CASES.values():
        session = load_session(folder / file)
        objective = replace(session.problem.objective, data=dict(session.problem.objective.data, steps=steps))
        problem = replace(session.problem, objective=objective)
        settings = make_settings("projection", session.model.algorithm.settings)
        runs.append(lambda i=0, p=problem, s=settings: list(iterate(Projection(), p, s, max_iter=s.max_iterations + 1)))
    times = interleaved_median_times(runs, repeat)
    out = {}
    for (name, (_, steps, target)), run, median in zip(PROJECTION_CASES.items(), runs, times):
        records = [r for _, r in run()]
        out[name] = {"median_s": median, "target_s": target, "met": median <= target, "steps": steps,
                     "iterations": len(records), "status": records[-1].status.value}
    return out


def slp_major_iteration(repeat: int) -> dict:
    """Report 003's launch vehicle in spirit (coebra_launch_vehicle.json: three
    flight conditions, 14 free variables, 27 measures): the first major
    iteration from the start (partials, then minor-loop trials until the
    relinearization); target 0.5 s, the report's 164 s per major iteration."""
    from pathlib import Path

    from engine.algorithm import make_settings
    from engine.slp import Slp
    from sessions.store import load_session
    path = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "coebra_launch_vehicle.json"
    samples, trials = [], 0
    for _ in range(max(repeat // 5, 3)):
        session = load_session(path)   # fresh networks: no cached realization
        settings = make_settings("slp", session.model.algorithm.settings)
        start = time.perf_counter()
        algorithm = Slp()
        state = algorithm.init(session.problem, settings)
        trials = 0
        while state.memory.major == 1 and not state.status.finished:
            state, _ = algorithm.step(state)
            trials += 1
        samples.append(time.perf_counter() - start)
    return {"median_s": statistics.median(samples), "target_s": 0.5, "minor_trials": trials,
            "free_variables": len(session.problem.free_slots()), "report_cdc_s": 164.0}


def sweep_throughput() -> dict:
    """32 starts of the launch-vehicle session limited to 2 major iterations (about
    a second a run): serially in this process, then on a local Dask cluster (one
    process per core), timed without and with starting the cluster."""
    import os
    from pathlib import Path

    from distributed import Client, LocalCluster

    from sessions.store import load_session
    from sessions.sweep_jobs import execute, execute_serial
    from sessions.sweeps import start_jobs
    session = load_session(Path(__file__).resolve().parents[2] / "sessions" / "examples" / "coebra_launch_vehicle.json")
    session.model.algorithm.settings["max_major"] = 2
    jobs = start_jobs(session, 32, spread=1.5, seed=11)
    start = time.perf_counter()
    serial = execute_serial(jobs)
    t_serial = time.perf_counter() - start
    start = time.perf_counter()
    cluster = LocalCluster(n_workers=os.cpu_count(), threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=40)
    client = Client(cluster)
    ready = time.perf_counter()
    parallel = execute(jobs, client=client)
    done = time.perf_counter()
    client.close()
    cluster.close()
    same = all(a["parameters"] == b["parameters"] for a, b in zip(serial.runs, parallel.runs))
    return {"runs": len(jobs), "workers": os.cpu_count(), "serial_s": t_serial, "mean_run_s": t_serial / len(jobs),
            "cluster_s": done - ready, "cluster_with_startup_s": done - start,
            "speedup": t_serial / (done - ready), "speedup_with_startup": t_serial / (done - start),
            "target_speedup": 1.6, "identical_results": same}


def median_time(fun, repeat: int) -> float:
    """Median wall time of fun(i) over i = 1..repeat, after one warm-up call."""
    fun(0)
    samples = []
    for i in range(1, repeat + 1):
        start = time.perf_counter()
        fun(i)
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def interleaved_median_times(funs: list, repeat: int) -> list[float]:
    """Median wall time of each fun(i), the functions called in turn at every
    i = 1..repeat (after one warm-up call each), so a change in the machine's
    speed during the run affects all of them alike and their ratios hold."""
    for fun in funs:
        fun(0)
    samples: list[list[float]] = [[] for _ in funs]
    for i in range(1, repeat + 1):
        for fun, times in zip(funs, samples):
            start = time.perf_counter()
            fun(i)
            times.append(time.perf_counter() - start)
    return [statistics.median(times) for times in samples]


def cli_startup(repeat: int) -> dict:
    """`loopcraft --help` against `python -c "import numpy, pydantic"`, each a fresh
    interpreter, timed interleaved (issue 18's target: at most 2x)."""
    import subprocess
    import sys

    def run(args: list[str]):
        return lambda i: subprocess.run([sys.executable, *args], check=True, capture_output=True)
    ours, baseline = interleaved_median_times([run(["-m", "tui.cli", "--help"]),
                                               run(["-c", "import numpy, pydantic"])], repeat)
    return {"median_s": ours, "baseline_numpy_pydantic_s": baseline, "ratio": ours / baseline,
            "target_ratio": 2.0, "met": ours / baseline <= 2.0}


def perturbed(params: dict, i: int) -> dict:
    """New parameter values each call (1e-12 relative), so no cache can answer."""
    return {k: v * (1.0 + 1e-12 * i) for k, v in params.items()}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="bench-results.json")
    parser.add_argument("--repeat", type=int, default=30)
    args = parser.parse_args()
    net, params, num, den = benchmark_loop()
    omega = np.geomspace(0.01, 1000.0, 1000)
    system = ct.tf(num, den)

    def response(i=0):
        return open_loop(net, "e", omega, perturbed(params, i))

    def all_margins(i=0):
        return margins(loop_model(net, "e", omega, perturbed(params, i)), attenuation_above=0.0)

    built = [loop_model(net, "e", omega, perturbed(params, i)) for i in range(3 * args.repeat + 1)]

    def margins_of_built_loop(i=0):
        """As python-control is timed: the loop exists, the margins are asked."""
        return margins(built[i], attenuation_above=0.0)

    def pc_margins(i=0):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return ct.stability_margins(system, returnall=True)

    r = response()
    assert r.sensitivity.shape == (1000, 30)
    t_resp = median_time(response, args.repeat)
    t_marg, t_marg_built, t_pc = interleaved_median_times([all_margins, margins_of_built_loop, pc_margins],
                                                          3 * args.repeat)
    t_pc_freq = median_time(lambda i: system(1j * omega), args.repeat)
    m = all_margins()
    qcg = qcg_comparison(args.repeat)
    from tests.bench.tui_latency import measure as tui_measure
    tui = tui_measure()
    cip_problem_ = cip_problem()
    t_cip, cip_steps = cip_iterations(cip_problem_, args.repeat)
    results = {
        "machine": {"python": platform.python_version(), "processor": platform.processor(),
                    "numpy": np.__version__, "control": ct.__version__},
        "loop": {"order": 2 * SECTIONS, "parameters": len(params), "frequencies": omega.size},
        "benchmarks": {
            "response_and_sensitivities": {"median_s": t_resp, "target_s": 0.005},
            "all_margins": {"median_s": t_marg, "includes": "building the loop at new parameter values",
                            "found": {"G": len(m.gain), "P": len(m.phase), "S": len(m.stability),
                                      "A": len(m.attenuation)}},
            "all_margins_of_built_loop": {"median_s": t_marg_built},
            "python_control_stability_margins": {"median_s": t_pc},
            "python_control_tf_response_no_sensitivities": {"median_s": t_pc_freq},
            "cip_iteration": {"median_s": t_cip, "target_s": 0.002, "frequencies": cip_problem_.grid.omega.size,
                              "channels": 2, "free_coefficients": len(cip_problem_.free_slots()),
                              "iterations_timed": len(cip_steps), "mean_trials": statistics.mean(cip_steps),
                              "report_univac_1106_s": 0.9},
            "qcg_sample_convergence": qcg,
            "workbench": tui,
            **projection_runs(args.repeat),
            "slp_major_iteration": slp_major_iteration(args.repeat),
            "sweep_throughput": sweep_throughput(),
            "cli_startup": cli_startup(min(args.repeat, 15)),
        },
        "ratios": {"python_control_margins_over_ours": t_pc / t_marg_built,
                   "python_control_margins_over_ours_with_building": t_pc / t_marg,
                   "python_control_tf_response_over_ours_with_sensitivities": t_pc_freq / t_resp,
                   "cip_target_over_ours": 0.002 / t_cip},
        "repeat": args.repeat,
    }
    with open(args.out, "w") as fh:
        json.dump(results, fh, indent=2, sort_keys=True)
    print(json.dumps(results["benchmarks"], indent=2))
    print(json.dumps(results["ratios"], indent=2))


if __name__ == "__main__":
    main()

"""Benchmarks (`make bench`): medians, and ratios against python-control run
in the same process on the same loop.  Writes JSON; prints a summary.

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


def median_time(fun, repeat: int) -> float:
    """Median wall time of fun(i) over i = 1..repeat, after one warm-up call."""
    fun(0)
    samples = []
    for i in range(1, repeat + 1):
        start = time.perf_counter()
        fun(i)
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


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

    def pc_margins(i=0):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return ct.stability_margins(system, returnall=True)

    r = response()
    assert r.sensitivity.shape == (1000, 30)
    t_resp = median_time(response, args.repeat)
    t_marg = median_time(all_margins, args.repeat)
    t_pc = median_time(pc_margins, args.repeat)
    t_pc_freq = median_time(lambda i: system(1j * omega), args.repeat)
    m = all_margins()
    results = {
        "machine": {"python": platform.python_version(), "processor": platform.processor(),
                    "numpy": np.__version__, "control": ct.__version__},
        "loop": {"order": 2 * SECTIONS, "parameters": len(params), "frequencies": omega.size},
        "benchmarks": {
            "response_and_sensitivities": {"median_s": t_resp, "target_s": 0.005},
            "all_margins": {"median_s": t_marg, "found": {"G": len(m.gain), "P": len(m.phase),
                                                          "S": len(m.stability), "A": len(m.attenuation)}},
            "python_control_stability_margins": {"median_s": t_pc},
            "python_control_tf_response_no_sensitivities": {"median_s": t_pc_freq},
        },
        "ratios": {"python_control_margins_over_ours": t_pc / t_marg,
                   "python_control_tf_response_over_ours_with_sensitivities": t_pc_freq / t_resp},
        "repeat": args.repeat,
    }
    with open(args.out, "w") as fh:
        json.dump(results, fh, indent=2, sort_keys=True)
    print(json.dumps(results["benchmarks"], indent=2))
    print(json.dumps(results["ratios"], indent=2))


if __name__ == "__main__":
    main()

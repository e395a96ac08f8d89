"""Benchmarks (`make bench`): every figure with its target and ``met``,
comparisons interleaved with the median of per-pair ratios, scaling studies
with fitted exponents.  Writes JSON, prints a summary, and exits 1 when an
enforced (ratio) target is missed.

    python -m tests.bench.run [--only margins,analyze] [--repeat N] [--out FILE]

Groups: see `GROUPS`."""

from __future__ import annotations

import argparse
import json
import platform
import sys
import traceback
from collections.abc import Callable

import control as ct
import numpy as np

from tests.bench import algorithms, analyze_path, loops, multiloop, plots, shaping, startup, tolerance
from tests.bench.common import missed, targets
from tests.bench.loops import benchmark_loop  # tests/engine/test_margins_reference.py imports it from here

__all__ = ["GROUPS", "benchmark_loop", "main"]

GROUPS: dict[str, Callable[[int], dict]] = {
    "margins": lambda r: {
        "margins_by_order": loops.margins_by_order(3 * r),
        "margins_with_building_order_40": loops.with_building(3 * r),
    },
    "response": lambda r: {"response_order_40": loops.responses(r)},
    "analyze": lambda r: {
        "analyze_path": analyze_path.analyze_path(r),
        "state_space_any_coordinates": analyze_path.state_space_any_coordinates(r),
    },
    "multiloop": lambda r: multiloop.multiloop_figures(r),
    "cip": lambda r: {"cip": algorithms.cip_figures(r)},
    "qcg": lambda r: {"qcg_sample_convergence": algorithms.qcg_figures(r)},
    "projection": lambda r: {"projection": algorithms.projection_figures(r)},
    "slp": lambda r: {"slp_major_iteration": algorithms.slp_major_iteration(r)},
    "workbench": lambda r: {"workbench": _workbench()},
    "plots": lambda r: {"bode_600_points_120x40": plots.bode_render(r)},
    "shaping": lambda r: {"shaping_nudge": shaping.nudge_latency(r), "shaping_drag": shaping.drag_latency(r)},
    "startup": lambda r: {"startup": startup.cli_startup(min(r, 15))},
    "sweep": lambda r: {"sweep_throughput": startup.sweep_throughput()},
    "tolerance": lambda r: {"tolerance_study": tolerance.tolerance_figures(r)},
    "studies": lambda r: {"tolerance_study_classes": tolerance.study_classes(max(3, r // 10))},  # issue 53's rows alone
    "cluster": lambda r: {"tolerance_study_cluster": tolerance.on_a_local_cluster(3)},  # issue 53's cluster row alone
}


def _workbench() -> dict:
    from tests.bench.tui_latency import measure

    return measure()


def summary(benchmarks: dict) -> list[str]:
    """One line per figure with a target: its path, value, target, met."""
    lines = []
    for path, figure in targets(benchmarks):
        value = next((figure[k] for k in ("ratio", "median_s", "max_wait_s", "value", "checked") if k in figure), None)
        shown = f"{value:.4g}" if isinstance(value, float) else str(value)
        flag = "met" if figure["met"] else ("MISSED" if figure["enforced"] else "missed (reported)")
        lines.append(f"{path:70s} {shown:>10s}  target {figure['target_kind']} {figure['target']}  {flag}")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench-results.json")
    parser.add_argument("--repeat", type=int, default=30, help="repetitions behind each median")
    parser.add_argument("--only", default="", help=f"comma-separated groups of {', '.join(GROUPS)}")
    args = parser.parse_args(argv)
    chosen = [g for g in args.only.split(",") if g] or list(GROUPS)
    unknown = [g for g in chosen if g not in GROUPS]
    if unknown:
        parser.error(f"unknown group(s) {', '.join(unknown)}; choose from {', '.join(GROUPS)}")
    benchmarks: dict = {}
    for group in chosen:
        print(f"-- {group}", file=sys.stderr, flush=True)
        try:
            benchmarks |= GROUPS[group](args.repeat)
        except Exception as exc:  # noqa: BLE001 - a group that crashes is a missed check; the others still run
            traceback.print_exc()
            benchmarks[f"{group}_failed"] = {
                "error": f"{type(exc).__name__}: {exc}",
                "target": "the group runs",
                "target_kind": "check",
                "met": False,
                "enforced": True,
            }
    failed = missed(benchmarks)
    results = {
        "machine": {
            "python": platform.python_version(),
            "processor": platform.processor(),
            "numpy": np.__version__,
            "control": ct.__version__,
        },
        "repeat": args.repeat,
        "groups": chosen,
        "benchmarks": benchmarks,
        "enforced_missed": failed,
    }
    with open(args.out, "w") as fh:
        json.dump(results, fh, indent=2, sort_keys=True)
    print("\n".join(summary(benchmarks)))
    if failed:
        print(f"{len(failed)} enforced target(s) missed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

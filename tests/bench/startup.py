"""Start-up (fresh interpreters, interleaved subprocess medians) and sweep
throughput (serially against a local Dask cluster)."""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from tests.bench.common import judged, samples, timed

ROOT = Path(__file__).resolve().parents[2]


def _command(args: list[str]):
    return lambda i=0: subprocess.run([sys.executable, *args], check=True, capture_output=True, cwd=ROOT)


def cli_startup(repeat: int) -> dict:
    """`loopcraft --help` (target 150 ms) and `loopcraft analyze --tf '1/(s+1)'`
    (target 400 ms) beside `python -c "import numpy, pydantic"` (issue 18's
    target: --help at most 2x that), interleaved; the first paint of the app
    in a fresh process (target 1 s)."""
    from tests.bench.tui_latency import first_paint

    help_, analyze, baseline = samples(
        [
            _command(["-m", "tui.cli", "--help"]),
            _command(["-m", "tui.cli", "analyze", "--tf", "1/(s+1)"]),
            _command(["-c", "import numpy, pydantic"]),
        ],
        repeat,
    )
    ratio = statistics.median([h / b for h, b in zip(help_, baseline)])
    return {
        "help": timed(statistics.median(help_), 0.150),
        "analyze_first_order": timed(statistics.median(analyze), 0.400),
        "baseline_numpy_pydantic_s": statistics.median(baseline),
        "help_over_baseline": {"ratio": ratio, **judged(ratio, 2.0, "max_ratio")},
        "app_first_paint": first_paint(max(repeat // 2, 3)),
    }


def sweep_throughput() -> dict:
    """32 starts of the launch-vehicle session limited to 2 major iterations (about
    a second a run): serially in this process, then on a local Dask cluster (one
    process per core), timed without and with starting the cluster (target 1.6x)."""
    from distributed import Client

    from sessions.store import load_session
    from sessions.sweeps.cluster import close, local_cluster
    from sessions.sweeps.jobs import execute, execute_serial
    from sessions.sweeps.plan import start_jobs

    session = load_session(ROOT / "sessions" / "examples" / "coebra_launch_vehicle.json")
    session.model.algorithm.settings["max_major"] = 2
    jobs = start_jobs(session, 32, spread=1.5, seed=11)
    start = time.perf_counter()
    serial = execute_serial(jobs)
    t_serial = time.perf_counter() - start
    start = time.perf_counter()
    cluster = local_cluster(os.cpu_count() or 1)  # as `loopcraft sweep` starts one
    client = Client(cluster)
    ready = time.perf_counter()
    parallel = execute(jobs, client=client)
    done = time.perf_counter()
    close(client, cluster)  # as the sweep closes them
    same = all(a["parameters"] == b["parameters"] for a, b in zip(serial.runs, parallel.runs))
    speedup, with_start = t_serial / (done - ready), t_serial / (done - start)
    return {
        "runs": len(jobs),
        "workers": os.cpu_count(),
        "serial_s": t_serial,
        "mean_run_s": t_serial / len(jobs),
        "cluster_s": done - ready,
        "cluster_with_startup_s": done - start,
        "speedup": {"ratio": speedup, **judged(speedup, 1.6, "min_ratio")},
        "speedup_with_startup": {"ratio": with_start, **judged(with_start, 1.6, "min_ratio")},
        "identical_results": {"value": same, "target": True, "target_kind": "check", "met": same, "enforced": True},
    }

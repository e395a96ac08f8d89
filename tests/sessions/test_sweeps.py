"""`loopcraft sweep`: planning (starts, vary, tolerance), a run's failure as data,
clustering into optima, the report-001 trade-off, and Dask: a local cluster,
and a real scheduler with two workers of which one is killed midway."""

from __future__ import annotations

import json
import math
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from sessions.errors import SessionError
from sessions.store import load_session
from sessions.sweeps.jobs import EVENT_TOPIC, loop_signature, run_job
from sessions.sweeps.plan import Job, shippable, start_jobs, tolerance_jobs, vary_jobs
from sessions.sweeps.results import adopt_run, optima, worst_case
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _copy(tmp_path: Path, name: str) -> Path:
    shutil.copy(EXAMPLES / f"{name}.json", tmp_path / f"{name}.json")
    for csv in EXAMPLES.glob("*.csv"):
        shutil.copy(csv, tmp_path / csv.name)
    return tmp_path / f"{name}.json"


def test_starts_are_log_uniform_within_bounds_and_reproducible(tmp_path):
    session = load_session(_copy(tmp_path, "coebra_lag_lead"))
    jobs = start_jobs(session, 400, seed=3)
    again = start_jobs(session, 400, seed=3)
    assert [j.start for j in jobs] == [j.start for j in again]
    t1 = np.array([j.start["T1"] for j in jobs])
    assert t1.min() >= 1e-3 and t1.max() <= 1e3
    logs = np.log10(t1)  # uniform on [-3, 3]: mean 0, standard deviation sqrt(3)
    assert abs(logs.mean()) < 0.3 and abs(logs.std() - math.sqrt(3.0)) < 0.2
    spread = start_jobs(session, 50, spread=2.0, seed=1)
    assert all(5.0 <= j.start["T1"] <= 20.0 for j in spread)  # within a factor 2 of 10


def test_shipped_sessions_carry_their_tables(tmp_path):
    """A remote worker has no files: CSV tables travel inline."""
    data = shippable(load_session(_copy(tmp_path, "seidel_inlet_pi")))
    text = json.dumps(data)
    assert ".csv" not in text and data["records"] == []
    result = run_job(Job(0, "here", data).payload())  # in this process, from any folder
    assert result["status"] == "converged" and result["parameters"]["b1"] == pytest.approx(47.41, abs=0.01)


def test_a_failing_run_is_a_result_not_an_exception(tmp_path):
    data = shippable(load_session(_copy(tmp_path, "coebra_lag_lead")))
    data["problem"]["parameters"][0]["value"] = "ten"  # invalid: the worker's validation fails
    result = run_job(Job(4, "broken", data).payload())
    assert result["status"] == "failed" and result["index"] == 4
    assert result["reason"].startswith("problem.parameters[0].value: Input should be")


def test_optima_cluster_by_parameters_and_objective():
    def run(i, T, objective, meets=True):
        return {
            "index": i,
            "status": "converged",
            "parameters": {"T1": T[0], "T2": T[1]},
            "ranking": objective,
            "meets_requirements": meets,
        }

    runs = [
        run(0, (1.0, 10.0), 29.0),
        run(1, (1.05, 10.2), 29.0),
        run(2, (5.0, 10.0), 29.0),
        run(3, (1.0, 10.0), 20.0, meets=False),
        {"index": 4, "status": "failed", "parameters": {}},
    ]
    found = optima(runs, maximize=True)
    assert [o["count"] for o in found] == [2, 1, 1]
    assert found[0]["best_run"] == 0 and found[0]["runs"] == [0, 1] and found[-1]["meets_requirements"] is False


def test_runs_with_the_same_loop_are_one_optimum_whatever_their_parameters(tmp_path):
    """(1+T1 s)(1+T2 s)/((1+T3 s)(1+T4 s)): swapping T1 and T2 is the same
    compensator, so the same loop and one optimum; moving a pole is not."""
    session = load_session(_copy(tmp_path, "coebra_lag_lead"))
    designs = [
        {"T1": 1.2, "T2": 0.7, "T3": 36.0, "T4": 0.03},
        {"T1": 0.7, "T2": 1.2, "T3": 36.0, "T4": 0.03},
        {"T1": 1.2, "T2": 0.7, "T3": 18.0, "T4": 0.03},
    ]
    runs = [
        {
            "index": i,
            "status": "converged",
            "parameters": d,
            "ranking": 29.0,
            "meets_requirements": True,
            "signature": loop_signature(session.problem, d),
        }
        for i, d in enumerate(designs)
    ]
    first, swapped = (np.array([complex(*p) for p in r["signature"]]) for r in runs[:2])
    np.testing.assert_allclose(first, swapped, rtol=1e-12)
    found = optima(runs, maximize=True)
    assert [o["runs"] for o in found] == [[0, 1], [2]]
    without = [{k: v for k, v in r.items() if k != "signature"} for r in runs]
    assert [o["count"] for o in optima(without, maximize=True)] == [1, 1, 1]  # by parameters: three


def test_worst_case_follows_each_measures_sense():
    def sample(i, pm, peak):
        return {
            "index": i,
            "measures": [
                {
                    "name": "PM1",
                    "kind": "phase_margin_deg",
                    "condition": "c",
                    "value": pm,
                    "desired": 30.0,
                    "satisfied": pm >= 30,
                    "at_least": True,
                },
                {
                    "name": "PK1",
                    "kind": "modal_peak_db",
                    "condition": "c",
                    "value": peak,
                    "desired": -6.0,
                    "satisfied": peak <= -6,
                    "at_least": False,
                },
            ],
        }

    rows = worst_case([sample(0, 40.0, -9.0), sample(1, 28.0, -7.0), sample(2, 35.0, -5.0)])
    assert (rows[0]["worst"], rows[0]["worst_sample"], rows[0]["unmet_samples"]) == (28.0, 1, 1)
    assert (rows[1]["worst"], rows[1]["worst_sample"], rows[1]["unmet_samples"]) == (-5.0, 2, 1)


def test_vary_and_tolerance_name_what_they_change(tmp_path):
    session = load_session(_copy(tmp_path, "coebra_kuo_digital"))
    jobs = vary_jobs(session, "targets[1].bands[0].desired=45,55")
    assert [j.model["problem"]["targets"][1]["bands"][0]["desired"] for j in jobs] == [45.0, 55.0]
    with pytest.raises(SessionError, match="not an objective option, a parameter, or a path"):
        vary_jobs(session, "nothing=1,2")
    samples = tolerance_jobs(session, ["T1=+-10%"], 20, seed=2)
    t1 = [j.start["T1"] for j in samples]
    assert all(18.0 <= v <= 22.0 for v in t1) and len(set(t1)) == 20
    with pytest.raises(SessionError, match="write NAME=\\+-10%"):
        tolerance_jobs(session, ["T1=ten"], 4)


def test_penalty_trade_off_is_monotone(tmp_path, capsys):
    """Report 001, Figure 4(a): as q2 grows the output rate falls and the output rises."""
    path = _copy(tmp_path, "seidel_inlet_pi")
    assert main(["sweep", str(path), "--vary", "q2=0,1e-5,1e-4,1e-3", "--serial", "--json"]) == 0
    runs = json.loads(capsys.readouterr().out)["runs"]
    output = [r["averaged_squares"]["x1_normalized"] for r in runs]
    rate = [r["averaged_squares"]["x1_rate_normalized"] for r in runs]
    assert all(r["status"] == "converged" for r in runs)
    assert np.all(np.diff(output) > 0) and np.all(np.diff(rate) < 0)
    saved = json.loads(path.read_text())["sweeps"]
    assert len(saved) == 1 and saved[0]["version"] == 2 and saved[0]["kind"] == "vary"


@pytest.mark.long
@pytest.mark.slow
def test_thirty_two_starts_on_a_local_cluster(tmp_path, capsys):
    """Report 003's 'map the hill' on the lag-lead example: some starts meet every
    requirement, some climb a local optimum that does not (Table B-3)."""
    path = _copy(tmp_path, "coebra_lag_lead")
    assert main(["sweep", str(path), "--starts", "32", "--workers", "2", "--json", "--adopt-best"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["workers"] == 2 and len(summary["runs"]) == 32 and not summary["failed"]
    workers = {r["worker"] for r in summary["runs"]}
    assert len(workers) == 2 and all(w.startswith("tcp://") for w in workers)  # both worker processes ran
    best = summary["optima"][0]
    assert best["meets_requirements"] and best["count"] >= 1
    assert sum(o["count"] for o in summary["optima"]) == 32
    saved = json.loads(path.read_text())
    assert saved["sweeps"][0]["optima"][0]["best_run"] == best["best_run"]
    adopted = {p["name"]: p["value"] for p in saved["problem"]["parameters"]}
    assert adopted == summary["runs"][best["best_run"]]["parameters"] and saved["records"] == []


@pytest.fixture
def dask_cluster(tmp_path):
    """A scheduler and two single-threaded workers on 127.0.0.1 (dask's own
    processes, no nanny: killing a worker kills it for good)."""
    file = tmp_path / "scheduler.json"
    processes = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(file),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    deadline = time.monotonic() + 30
    while not file.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    address = json.loads(file.read_text())["address"]
    for _ in range(2):
        processes.append(
            subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "distributed.cli.dask_worker",
                    address,
                    "--nthreads",
                    "1",
                    "--no-nanny",
                    "--no-dashboard",
                ],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
    from distributed import Client

    with Client(address, timeout="30s") as client:
        client.wait_for_workers(2, timeout=30)
    yield address, processes
    for p in processes:
        p.kill()
        p.wait()


def _kill_the_first_busy_worker(address: str, processes: list, killed: list, stop: threading.Event) -> None:
    """Kill the worker on which a run starts first (each run logs its start and its worker on
    the scheduler), while that run is going: the condition, not a timer."""
    import os

    from distributed import Client

    with Client(address, timeout="30s") as client:
        pids = client.run(os.getpid)  # worker address -> its process id
        while not stop.wait(0.02):
            events = client.get_events(EVENT_TOPIC)
            if events:
                pid = pids[events[0][1]["worker"]]
                victim = next(p for p in processes if p.pid == pid)
                victim.send_signal(signal.SIGKILL)
                killed.append(victim)
                return


@pytest.mark.long
@pytest.mark.slow
def test_a_worker_killed_midway_is_recorded_and_the_sweep_finishes(dask_cluster, tmp_path, capsys):
    address, processes = dask_cluster
    path = _copy(tmp_path, "coebra_launch_vehicle")  # runs of a few seconds each
    killed: list = []
    stop = threading.Event()
    killer = threading.Thread(target=_kill_the_first_busy_worker, args=(address, processes, killed, stop))
    killer.start()
    try:
        assert main(["sweep", str(path), "--starts", "4", "--spread", "1.5", "--scheduler", address, "--json"]) == 0
    finally:
        stop.set()
        killer.join(timeout=30)
    summary = json.loads(capsys.readouterr().out)
    assert killed and killed[0].poll() is not None  # the worker is gone
    runs = summary["runs"]
    assert len(runs) == 4
    assert all(r["status"] != "failed" or r["reason"] for r in runs)
    assert summary["retried"], "the run that was on the killed worker was restarted elsewhere"
    for index, workers in summary["retried"].items():
        assert len(workers) >= 2 and runs[int(index)]["attempts"] >= 2
    started = {w for workers in summary["retried"].values() for w in workers if w != "a lost worker"}
    finished = {r["worker"] for r in runs if r["status"] != "failed"}
    assert summary["workers"] == len(started | finished) >= 1  # the workers known to have computed runs


def test_a_tolerance_sample_outside_the_design_bounds_is_evaluated_at_its_value(tmp_path, capsys):
    """Issue 37 section 4: a parameter at its design bound, +-10 %: every sample is
    evaluated at its drawn value (half of them failed with pydantic's dump), and a sample
    adopted as the start widens the bounds to hold it, saying so."""
    path = _copy(tmp_path, "coebra_lag_lead")
    data = json.loads(path.read_text())
    t2 = next(p for p in data["problem"]["parameters"] if p["name"] == "T2")
    t2["min"] = t2["value"]  # the design sits at its lower bound
    path.write_text(json.dumps(data))
    session = load_session(path)
    jobs = tolerance_jobs(session, ["T2=+-10%"], 12, seed=1)
    below = [j for j in jobs if j.start["T2"] < t2["value"]]
    assert below  # samples under the design bound exist
    results = [run_job(j.payload()) for j in below]
    assert all(r["status"] != "failed" for r in results), [r.get("reason") for r in results]
    lowest = min(below, key=lambda j: j.start["T2"])
    widened = adopt_run(session, {"index": lowest.index, "status": "evaluated", "parameters": lowest.start})
    t2_model = next(p for p in session.model.problem.parameters if p.name == "T2")
    assert t2_model.min == lowest.start["T2"] and len(widened) == 1 and "widened" in widened[0]


def test_a_sample_that_fails_says_why_in_one_line_without_a_library_dump(tmp_path):
    session = load_session(_copy(tmp_path, "coebra_lag_lead"))
    job = tolerance_jobs(session, ["T1=+-10%"], 1)[0]
    payload = job.payload()
    payload["model"]["problem"]["parameters"][0]["value"] = "ten"
    result = run_job(payload)
    assert result["status"] == "failed" and "pydantic" not in result["reason"] and "\n" not in result["reason"]
    assert "problem.parameters[0].value" in result["reason"]

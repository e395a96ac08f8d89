"""Sweeps under faults: Ctrl-C keeps the finished runs, a bad or unreachable
scheduler and a worker dying at start-up are clean errors, and a sweep's
results are never lost (an output checked before the runs, a recovery file
when the session cannot be saved)."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sessions.errors import SessionError
from sessions.store import load_session
from sessions.sweeps.cluster import scheduler_address
from sessions.sweeps.jobs import SECOND_TIMING, Outcome, execute, execute_serial
from sessions.sweeps.plan import parse_sweep, start_jobs
from sessions.sweeps.results import record_sweep, summarize
from tui.cli import main
from tui.cli.sweep import with_former_keys

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "sessions" / "examples"


def _copy(tmp_path: Path, name: str) -> Path:
    shutil.copy(EXAMPLES / f"{name}.json", tmp_path / f"{name}.json")
    return tmp_path / f"{name}.json"


@pytest.mark.parametrize(
    "address",
    [
        "tcp://127.0.0.1",
        "nonsense",
        "inproc://x",
        "tls://127.0.0.1:1",
        "",
        "tcp://127.0.0.1:0",
        "tcp://127.0.0.1:65536",
        "tcp://:8786",
        "tcp://127.0.0.1:8786/path",
        "tcp://a b:1",
    ],
)
def test_a_bad_scheduler_address_is_refused_before_anything_starts(tmp_path, capsys, address):
    path = _copy(tmp_path, "coebra_lag_lead")
    began = time.monotonic()
    assert main(["sweep", str(path), "--starts", "2", "--scheduler", address]) == 2
    assert time.monotonic() - began < 2.0
    assert "write tcp://HOST:PORT (PORT 1-65535)" in capsys.readouterr().err
    with pytest.raises(SessionError, match="write tcp://HOST:PORT"):
        parse_sweep(f"starts 4 at {address or 'x'}")


def test_good_addresses_are_kept():
    assert scheduler_address("tcp://127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    assert scheduler_address(" tcp://Scheduler.example:1 ") == "tcp://scheduler.example:1"
    assert scheduler_address("tcp://[::1]:65535") == "tcp://[::1]:65535"
    assert scheduler_address(None) is None


@pytest.mark.slow
def test_an_unreachable_scheduler_is_given_up_after_the_connect_timeout(tmp_path, capsys):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    path = _copy(tmp_path, "coebra_lag_lead")
    began = time.monotonic()
    assert (
        main(["sweep", str(path), "--starts", "2", "--scheduler", f"tcp://127.0.0.1:{port}", "--connect-timeout", "1"])
        == 2
    )
    assert time.monotonic() - began < 6.0
    assert f"cannot reach the Dask scheduler tcp://127.0.0.1:{port} within 1 s" in capsys.readouterr().err
    for bad in ("0", "-1", "nan", "inf"):
        assert main(["sweep", str(path), "--starts", "2", "--connect-timeout", bad]) == 2
        assert "--connect-timeout" in capsys.readouterr().err


def test_a_worker_dying_at_start_up_is_a_clean_error(tmp_path, capsys):
    import dask

    path = _copy(tmp_path, "coebra_lag_lead")
    with dask.config.set({"distributed.worker.preload": ["loopcraft_no_such_module"]}):  # the worker dies
        assert main(["sweep", str(path), "--starts", "2", "--workers", "1"]) == 2
    assert "cannot start a local Dask cluster of 1 worker(s): Nanny failed to start" in capsys.readouterr().err
    assert not json.loads(path.read_text()).get("sweeps")


@pytest.mark.long
@pytest.mark.slow
def test_ctrl_c_on_a_serial_sweep_keeps_the_finished_runs(tmp_path):
    """A real SIGINT to the process group, as a terminal's Ctrl-C sends it."""
    path = _copy(tmp_path, "coebra_launch_vehicle")  # runs of a few seconds each
    child = subprocess.Popen(
        [sys.executable, "-m", "tui.cli", "sweep", str(path), "--starts", "12", "--spread", "1.5", "--serial"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    time.sleep(7.0)
    os.killpg(child.pid, signal.SIGINT)
    out, err = child.communicate(timeout=60)
    assert child.returncode == 130 and "Traceback" not in err, err
    finished = int(re.search(r"interrupted: (\d+) of 12 runs finished; kept in .* as a cancelled sweep", err)[1])
    sweep = json.loads(path.read_text())["sweeps"][-1]
    assert sweep["cancelled"] and len(sweep["runs"]) == 12
    assert sum(r["reason"] != "cancelled" for r in sweep["runs"]) == finished
    assert "start 0" in out


def _interrupt_after(n: int):
    def progress(done: int, total: int) -> None:
        if done >= n:
            raise KeyboardInterrupt

    return progress


def test_an_interrupted_serial_execution_is_an_outcome(tmp_path):
    jobs = start_jobs(load_session(_copy(tmp_path, "coebra_lag_lead")), 5, seed=1)
    outcome = execute_serial(jobs, _interrupt_after(2))
    assert outcome.interrupted and outcome.cancelled and outcome.finished == 2
    assert [r["reason"] for r in outcome.runs[2:]] == ["cancelled"] * 3 and len(outcome.runs) == 5


@pytest.mark.long
@pytest.mark.slow
def test_an_interrupted_dask_execution_keeps_what_finished(tmp_path):
    jobs = start_jobs(load_session(_copy(tmp_path, "coebra_lag_lead")), 6, seed=1)
    outcome = execute(jobs, workers=2, progress=_interrupt_after(1))
    assert outcome.interrupted and outcome.cancelled and len(outcome.runs) == 6
    assert 1 <= outcome.finished <= 6
    assert all(r["status"] != "failed" for r in outcome.runs if r["reason"] != "cancelled")


def test_an_output_that_cannot_be_written_is_refused_before_the_runs(tmp_path, capsys):
    path = _copy(tmp_path, "coebra_lag_lead")
    (tmp_path / "a-file").write_text("")
    for out, said in (
        (tmp_path / "missing" / "x.json", "does not exist"),
        (tmp_path / "a-file" / "x.json", "does not exist"),
        (tmp_path, "a folder, not a regular file"),
    ):
        began = time.monotonic()
        assert main(["sweep", str(path), "--starts", "200", "--serial", "--out", str(out)]) == 2
        assert said in capsys.readouterr().err and time.monotonic() - began < 2.0  # no run was made


@pytest.mark.slow
def test_a_session_that_cannot_be_saved_leaves_a_recovery_file(tmp_path, capsys, monkeypatch):
    import sessions.store

    def full(*args, **kwargs):
        raise SessionError("x.json: cannot save: No space left on device")

    monkeypatch.setattr(sessions.store, "save_session", full)
    path = _copy(tmp_path, "coebra_lag_lead")
    assert main(["sweep", str(path), "--starts", "3", "--serial", "--json"]) == 2
    out, err = capsys.readouterr()
    recovery = tmp_path / "coebra_lag_lead.sweep-recovery.json"
    saved = json.loads(recovery.read_text())
    assert with_former_keys(saved["sweep"])["runs"] == json.loads(out)["runs"] and saved["session"] == str(path)
    assert f"No space left on device; the sweep's results are in {recovery}" in err


def test_non_finite_objectives_are_kept_as_json(tmp_path):
    session = load_session(_copy(tmp_path, "coebra_lag_lead"))
    runs = [
        {
            "index": 0,
            "label": "start 0",
            "start": {},
            "status": "converged",
            "reason": "",
            "parameters": {"T1": 1.0},
            "ranking": math.inf,
            "measures": [],
            "meets_requirements": True,
            "iterations": 3,
            "attempts": 1,
        }
    ]
    summary = summarize(session, "starts", {}, Outcome(runs, 1))
    record_sweep(session, summary)
    assert summary["runs"][0]["ranking"] == "inf"
    from sessions.store import dumps

    assert json.loads(dumps(session.model))["sweeps"][0]["runs"][0]["ranking"] == "inf"


@pytest.mark.slow
def test_a_sweep_too_small_for_a_local_cluster_runs_serially_and_says_so(tmp_path):
    jobs = start_jobs(load_session(_copy(tmp_path, "coebra_lag_lead")), 4, seed=1)
    outcome = execute(jobs)
    timed = 2 if outcome.runs[0]["seconds"] <= SECOND_TIMING else 1  # a short first run is timed again
    assert outcome.workers == 1 and outcome.note.startswith(f"serial: the {4 - timed} other run(s) take about")
    serial = execute_serial(jobs)
    assert [r["parameters"] for r in outcome.runs] == [r["parameters"] for r in serial.runs]
    kept = summarize(load_session(_copy(tmp_path, "coebra_lag_lead")), "starts", {"scheduler": "local"}, outcome)
    assert kept["settings"] == {"scheduler": "serial", "note": outcome.note}  # as saved in the session


def _worker_view() -> dict:
    import sys

    import dask

    return {
        "profile": dask.config.get("distributed.worker.profile.enabled"),
        "preload": list(dask.config.get("distributed.worker.preload")),
        "warm": "engine.slp" in sys.modules and "sessions.sweeps.jobs" in sys.modules,
        "environ": {name: os.environ.get(name) for name in ("MALLOC_TRIM_THRESHOLD_", "OPENBLAS_NUM_THREADS")},
    }


@pytest.mark.long
@pytest.mark.slow
def test_a_local_cluster_is_quiet_and_preloaded_after_the_configured_preloads(monkeypatch):
    """Dask's statistical profiler (a stack sample every 10 ms) is off on our local workers,
    which import the engine and the algorithms as they start; a preload the user
    configured comes first.  Dask's MALLOC_TRIM_THRESHOLD_ is not set on them (glibc's
    fixed thresholds made a launch-vehicle run 1.45 times as long as in this process);
    its one BLAS thread per worker is kept."""
    import dask
    from distributed import Client

    from sessions.sweeps.cluster import local_cluster

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with dask.config.set({"distributed.worker.preload": ["json"]}):
        cluster = local_cluster(1)
    try:
        with Client(cluster) as client:
            (seen,) = client.run(_worker_view).values()
    finally:
        cluster.close()
    assert seen == {
        "profile": False,
        "preload": ["json", "sessions.sweeps.worker_preload"],
        "warm": True,
        "environ": {"MALLOC_TRIM_THRESHOLD_": None, "OPENBLAS_NUM_THREADS": "1"},
    }
    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": 1 << 20}):
        cluster = local_cluster(1)  # a threshold configured on purpose is kept
    try:
        with Client(cluster) as client:
            (seen,) = client.run(_worker_view).values()
    finally:
        cluster.close()
    assert seen["environ"]["MALLOC_TRIM_THRESHOLD_"] == str(1 << 20)


@pytest.mark.parametrize(
    ("line", "said"),
    [
        ("starts 100001", "--starts: 100001 is not in 1..100000"),
        ("starts 0", "--starts: 0 is not in 1..100000"),
        ("tolerance T1=+-10% samples 1000000001", "--samples: 1000000001 is not in 1..1000000"),
        ("tolerance T1=+-10% samples 0", "--samples: 0 is not in 1..1000000"),
    ],
)
def test_a_sweep_beyond_its_size_is_refused_when_planned_whoever_asks(line, said):
    """The app's Sweep tab plans from one line with no option bounds of its own: a sweep
    of 10^9 samples drew 8 GB of deviations a parameter, 10^7 starts copied the session
    10^7 times.  The plan refuses them with the command line's bounds (one limit each,
    `sessions.format.limits`), before any allocation."""
    from sessions.sweeps.plan import plan

    session = load_session(EXAMPLES / "coebra_lag_lead.json")
    spec = parse_sweep(line)
    with pytest.raises(SessionError) as refused:
        plan(session, spec["kind"], spec["value"], seed=0, samples=spec.get("samples", 32))
    assert str(refused.value) == said

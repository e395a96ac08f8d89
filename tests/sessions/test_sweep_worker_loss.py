"""A tolerance study on a `dask scheduler` and two `dask worker` processes started here on
127.0.0.1 (real processes, not the in-process cluster), one of which is killed midway:
every sample's result is found once, and equals a serial run's (issue 41, section 3); the
sweep's bookkeeping is the scheduler's: workers that computed, attempts and retries as its
transition log has them (issue 50).  The study goes to the workers in chunks of samples
(issue 53, section 2): the kill comes while the victim is on a chunk."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import pytest

from engine.stepping.memory_fields import jsonable
from sessions.store import load_session
from sessions.sweeps.jobs import EVENT_TOPIC, execute_serial
from sessions.sweeps.plan import tolerance_jobs
from tests.sessions.study_agreement import assert_measures_agree

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "sessions" / "examples"
# lag-lead samples batched: a probe of 500 per worker, then 4 chunks of 2250 (at least two per worker on a
# running scheduler), every run kept (a study of at most 10 000)
SAMPLES = 10_000
VICTIM = "victim"  # the worker killed midway


def _copy(tmp_path: Path) -> Path:
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", tmp_path / "s.json")
    return tmp_path / "s.json"


def _started(arguments: list[str], environment: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", *arguments],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=None if environment is None else {**os.environ, **environment},
    )


@contextmanager
def _scheduler_and_workers(tmp_path: Path, names: tuple[str, ...], environment: dict | None = None):
    """`dask scheduler` (its configuration from ``environment``) and a `dask worker` process per
    name on 127.0.0.1, ports chosen by the system (the scheduler's written to its scheduler file);
    the workers without a nanny, so that a killed one stays dead.  Every process is killed at the end."""
    from distributed import Client

    file = tmp_path / "scheduler.json"
    processes = [
        _started(
            ["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard"]
            + ["--scheduler-file", str(file)],
            environment,
        )
    ]
    try:
        deadline = time.monotonic() + 30
        while not file.exists() and time.monotonic() < deadline and processes[0].poll() is None:
            time.sleep(0.05)
        assert file.exists(), "the scheduler did not start within 30 s"
        address = json.loads(file.read_text())["address"]
        for name in names:
            processes.append(
                _started(
                    ["distributed.cli.dask_worker", address, "--host", "127.0.0.1", "--nthreads", "1"]
                    + ["--no-nanny", "--no-dashboard", "--name", name]
                )
            )
        with Client(address, timeout="30s") as client:
            client.wait_for_workers(len(names), timeout=30)
            yield client, address, processes
    finally:
        for process in processes:
            process.kill()
        for process in processes:
            process.wait(timeout=30)


@pytest.fixture
def scheduler_and_two_workers(tmp_path):
    """A scheduler and two workers, ``survivor`` and `VICTIM` (`_scheduler_and_workers`)."""
    with _scheduler_and_workers(tmp_path, ("survivor", VICTIM)) as cluster:
        yield cluster


def _kill_on_a_chunk(client, worker: subprocess.Popen, stop: threading.Event) -> None:
    """Kill ``worker`` (the one named `VICTIM`) while a chunk is on it, once it has started two
    (each chunk logs its start on the scheduler): it has finished its probe at least.  Whether a
    chunk is still on it is asked of the scheduler with the worker stopped (SIGSTOP), so it
    cannot finish that chunk between the look and the kill; with none on it, it goes on
    (SIGCONT) and is looked at again.  (Killed at its third start, as it was, the victim could
    finish that chunk, its last, before the watch saw the start on a loaded machine, or start
    only two when the survivor took the third: then nothing was retried, or nothing killed.)"""
    victim = next(a for a, w in client.scheduler_info()["workers"].items() if w["name"] == VICTIM)

    def chunks_on(dask_scheduler, address: str) -> int:
        state = dask_scheduler.workers.get(address)
        return 0 if state is None else sum(str(task.key).startswith("loopcraft-") for task in state.processing)

    while not stop.wait(0.02):
        started = [e for _, e in client.get_events(EVENT_TOPIC) if e.get("chunk") and e["worker"] == victim]
        if len(started) < 2:
            continue
        worker.send_signal(signal.SIGSTOP)
        if client.run_on_scheduler(chunks_on, address=victim):
            worker.send_signal(signal.SIGKILL)
            return
        worker.send_signal(signal.SIGCONT)


def _times_sent(client) -> dict[str, int]:
    """Each loopcraft task's transitions to processing in the scheduler's log."""

    def log(dask_scheduler) -> list[tuple[str, str]]:
        return [(str(t[0]), t[2]) for t in dask_scheduler.transition_log]

    sent: dict[str, int] = {}
    for key, finish in client.run_on_scheduler(log):
        if key.startswith("loopcraft-") and finish == "processing":
            sent[key] = sent.get(key, 0) + 1
    return sent


@pytest.mark.long
@pytest.mark.slow
def test_a_worker_killed_midway_through_a_tolerance_study_loses_no_sample(scheduler_and_two_workers, tmp_path):
    """The sweep in a process of its own, as it is run (this process's client only watches
    the scheduler's log of the runs' starts: two clients in one process share futures'
    events across event loops)."""
    client, address, processes = scheduler_and_two_workers
    path = _copy(tmp_path)
    jobs = tolerance_jobs(load_session(path), ["T1=+-10%"], SAMPLES)  # as the sweep plans them
    stop = threading.Event()
    killer = threading.Thread(target=_kill_on_a_chunk, args=(client, processes[2], stop))
    killer.start()
    try:
        argv = ["sweep", str(path), "--tolerance", "T1=+-10%", "--samples", str(SAMPLES), "--scheduler", address]
        done = subprocess.run(
            [sys.executable, "-m", "tui.cli", *argv, "--json"], cwd=ROOT, capture_output=True, text=True, timeout=120
        )
    finally:
        stop.set()
        killer.join(timeout=10)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert processes[2].poll() is not None, "the worker was killed midway"
    runs = summary["runs"]
    assert not summary["failed"], {runs[k]["reason"] for k in summary["failed"]}
    assert summary["workers"] == 2  # both computed runs: the killed one before it died
    assert summary["retried"], "the runs of the batch on the killed worker were started again on the other"
    attempts = {r["index"]: r["attempts"] for r in runs}
    for index, workers in summary["retried"].items():
        assert attempts[int(index)] == len(workers) >= 2
    for key, sent in _times_sent(client).items():  # the scheduler's own log, read here
        first, stop = (int(part) for part in key.split("-")[2:4])  # loopcraft-TAG-FIRST-STOP: the chunk's samples
        assert all(attempts[k] >= sent for k in range(first, stop)), (key, sent)
    assert sum(sent > 1 for sent in _times_sent(client).values()) >= 1
    assert len(_times_sent(client)) < SAMPLES // 100  # chunks of samples, not a task per sample
    assert sorted(r["index"] for r in runs) == list(range(SAMPLES))  # every sample's result, once
    assert "samples sent to the workers in" in done.stderr, done.stderr
    serial = jsonable([[r["start"], r["measures"]] for r in execute_serial(jobs).runs])
    kept = json.loads(path.read_text())["sweeps"][-1]["runs"]  # as saved ("target" is only in --json's)
    assert [r["start"] for r in kept] == [start for start, _ in serial]
    assert_measures_agree([r["measures"] for r in kept], [measures for _, measures in serial])


@pytest.mark.long
@pytest.mark.slow
def test_a_study_whose_workers_all_die_finishes_with_its_lost_chunks_recorded(tmp_path, monkeypatch):
    """A poisoned chunk kills its worker, and its retry the other one (no nanny restarts them;
    ``allowed-failures`` 0): the chunks left, sent again as halves, would wait for a worker
    forever (the study hung over 10 minutes).  The wait is bounded: the cluster without a worker
    for `NO_WORKER_WAIT` (2 s here: no worker can come back), the study finishes, every sample
    once, the samples not computed recorded as failed with the status and named in the note,
    those computed equal to the serial study's."""
    from sessions.sweeps import cluster
    from sessions.sweeps.cluster import NOT_COMPUTED, Connection
    from sessions.sweeps.study_chunks import run_chunked
    from tests.sessions.sweep_poison import POISON, poisoned_chunk

    monkeypatch.setattr(cluster, "NO_WORKER_WAIT", 2.0)
    samples = tolerance_jobs(load_session(_copy(tmp_path)), ["T1=+-10%", "T2=+-10%"], 64, seed=4)
    environment = {"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"}
    with _scheduler_and_workers(tmp_path, ("one", "two"), environment) as (client, _, processes):
        outcome = run_chunked(Connection(client, None, 0), samples, task=poisoned_chunk)
        assert all(process.poll() is not None for process in processes[1:]), "both workers died"
    runs = outcome.runs
    assert [r["index"] for r in runs] == list(range(64))
    failed = {r["index"] for r in runs if r["status"] == "failed"}
    lost = {r["index"] for r in runs if r["reason"].startswith(NOT_COMPUTED)}
    assert POISON in failed and lost and lost <= failed, (failed, lost)
    assert all(runs[k]["reason"].startswith(NOT_COMPUTED) or "workers died" in runs[k]["reason"] for k in failed)
    assert outcome.given_up.startswith(f"{NOT_COMPUTED}: the cluster had no worker for 2 s")
    assert outcome.given_up in outcome.note and f"({len(lost)} samples recorded as failed)" in outcome.note
    assert outcome.note.startswith(f"{64 - len(lost)} of {64 - len(lost)} samples evaluated")  # the lost ones left out
    serial = execute_serial(samples).runs
    kept = [k for k in range(64) if k not in failed]
    assert_measures_agree([runs[k]["measures"] for k in kept], [serial[k]["measures"] for k in kept])

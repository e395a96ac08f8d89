"""Short runs go to the workers in batches: a Dask task costs a few ms of its own,
so 2 ms runs went no faster on two workers than serially.  The batches keep the
runs' order and results, and a cancelled batch cancels each of its runs."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from sessions.store import load_session
from sessions.sweeps.jobs import _gather, batch_size, execute_serial
from sessions.sweeps.plan import start_jobs

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


@pytest.mark.parametrize(
    ("each", "count", "workers", "size"),
    [
        (0.6, 32, 2, 1),  # long runs: one per task
        (0.002, 4000, 2, 125),  # 2 ms runs: a quarter of a second of work per task
        (0.002, 100, 2, 12),  # ... but at least four tasks per worker
        (0.002, 3, 2, 1),
        (0.05, 1000, 2, 5),
        (0.0, 10, 1, 2),
        (0.001, 10, 0, 2),
    ],
)
def test_batch_size(each, count, workers, size):
    assert batch_size(each, count, workers) == size


@pytest.fixture(scope="module")
def client():
    from distributed import Client

    from sessions.sweeps.cluster import close, local_cluster

    cluster = local_cluster(2)
    client = Client(cluster)
    yield client
    close(client, cluster)


def _jobs(tmp_path: Path, count: int):
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", tmp_path / "s.json")
    return start_jobs(load_session(tmp_path / "s.json"), count, seed=4)


@pytest.mark.long
@pytest.mark.slow
def test_batches_give_the_serial_runs_in_order(tmp_path, client):
    jobs = _jobs(tmp_path, 7)
    seen = []
    outcome = _gather(client, jobs, lambda done, total: seen.append((done, total)), lambda: False, size=3)
    serial = execute_serial(jobs)
    assert [r["index"] for r in outcome.runs] == [j.index for j in jobs]
    assert [r["parameters"] for r in outcome.runs] == [r["parameters"] for r in serial.runs]
    assert seen[-1] == (7, 7) and len(seen) == 3  # a progress report per batch of 3, 3 and 1
    assert all(r["attempts"] == 1 and r["worker"].startswith("tcp://") for r in outcome.runs)


@pytest.mark.slow
def test_a_cancelled_sweep_cancels_every_run_of_a_batch_not_finished(tmp_path, client):
    jobs = _jobs(tmp_path, 12)
    outcome = _gather(client, jobs, None, lambda: True, size=4)  # cancelled at the first finished batch
    assert outcome.cancelled and len(outcome.runs) == 12
    finished = [r for r in outcome.runs if r["reason"] != "cancelled"]
    assert len(finished) % 4 == 0 and 4 <= len(finished) <= 12  # whole batches, at least the first


@pytest.mark.long
@pytest.mark.slow
def test_a_run_that_kills_its_worker_does_not_take_its_batch_with_it(tmp_path):
    import dask
    from distributed import Client

    from sessions.sweeps.cluster import close, local_cluster
    from tests.sessions.sweep_poison import POISON, poisoned

    jobs = _jobs(tmp_path, 8)
    # one death fails the task it ran; a worker holds one task at a time (none queued behind the poison)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0, "distributed.scheduler.worker-saturation": 1.0}):
        cluster = local_cluster(2)
    client = Client(cluster)
    try:
        outcome = _gather(client, jobs, None, lambda: False, size=4, task=poisoned)
    finally:
        close(client, cluster)
    assert [r["index"] for r in outcome.runs] == [j.index for j in jobs]
    failed = [r for r in outcome.runs if r["status"] == "failed"]
    assert [r["index"] for r in failed] == [POISON] and "workers died while running it" in failed[0]["reason"]


class _Job:
    """A job as `execute` reads it: its payload, index, label and start."""

    def __init__(self, index: int):
        self.index, self.label, self.start = index, f"start {index}", {}

    def payload(self) -> dict:
        return {"index": self.index}


@pytest.mark.parametrize(("first", "timed"), [(0.6, 2), (1.5, 1)])
def test_a_short_first_run_is_timed_again_on_the_second(monkeypatch, first, timed):
    """The first run pays for the imports made on first use (0.4-0.8 s against 5-9 ms
    for a tolerance run of the lag-lead loop): a second is timed when the first was short."""
    import sessions.sweeps.jobs as sweep_jobs

    seconds = iter([first] + [0.004] * 1000)
    monkeypatch.setattr(sweep_jobs, "run_job", lambda payload: {"index": payload["index"], "seconds": next(seconds)})
    here, each, serial = sweep_jobs._first_here([_Job(k) for k in range(1000)], None)
    assert len(here) == timed and each == (0.004 if timed == 2 else first)
    assert (serial is not None) == (timed == 2)  # 998 runs of 4 ms: here; 999 of 1.5 s: on a cluster
    if serial is not None:
        assert serial.serial and serial.note.startswith("serial: the 998 other run(s) take about 4 s here")
        assert [r["index"] for r in serial.runs] == list(range(1000))

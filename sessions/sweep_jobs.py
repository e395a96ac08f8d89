"""Sweep jobs on a Dask worker, and running a sweep's jobs.

What is shipped to a worker is data only: the session's JSON document (its
CSV tables inlined, so a remote worker needs no files) and a job number; the
worker runs `run_job`, a function of this module that workers import (they
need loopcraft installed), and sends back plain JSON (the final StepRecord's
content, summarized by the algorithm's presenter).  Without an address a
local cluster is started with one process per core, one thread each; with
``tcp://HOST:PORT`` that cluster is used.

A job that fails (a singular matrix, a worker that dies twice) is recorded
as failed with its reason; the sweep goes on.  Each job logs a "started"
event on the scheduler, so a job that had to be restarted on another worker
is reported with its attempts.
"""

from __future__ import annotations

import os
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from engine.algorithm import StepRecord, iterate
from engine.errors import EngineError
from engine.loops import open_loop
from engine.problem import Problem

from .build import build_problem
from .errors import SessionError
from .lifecycle import bind
from .schema import SessionModel

MAX_ITERATIONS = 1000
EVENT_TOPIC = "loopcraft-sweep"
SIGNATURE_POINTS = 24      # frequencies (grid points spread over the grid) of a run's loop signature


def run_job(payload: dict) -> dict:
    """Run (or evaluate) one job; never raises: a failure is a result."""
    began = time.perf_counter()
    worker = _announce(payload["index"])
    result = {"index": payload["index"], "label": payload["label"], "start": payload["start"], "worker": worker}
    try:
        model = SessionModel.model_validate(payload["model"])
        problem = build_problem(model.problem, Path.cwd())
        registration, algorithm, settings = bind(model.algorithm)
        if payload["mode"] == "evaluate":
            record = _evaluate(registration.presenter, algorithm, problem, settings)
        else:
            record = None
            for _, record in iterate(algorithm, problem, settings, max_iter=MAX_ITERATIONS):
                pass
            if record is None:
                raise SessionError("the algorithm made no iteration")
        result.update(_summary(registration.presenter, record))
        if payload["mode"] != "evaluate":
            result["signature"] = loop_signature(problem, record.parameters)
    except Exception as exc:  # noqa: BLE001 - a run's failure is data, never the sweep's end
        result.update(status="failed", reason=f"{type(exc).__name__}: {exc}", parameters={}, objective=None,
                      measures=[], meets_requirements=False, iterations=0)
    result["seconds"] = time.perf_counter() - began
    return result


def _evaluate(presenter, algorithm, problem, settings) -> StepRecord:
    """The tableau of the design as it is: iteration 0's record, as the presenter gives it."""
    record = presenter.initial_record(algorithm, algorithm.init(problem, settings), problem)
    if record is None:
        raise SessionError("the design's tableau cannot be computed")
    return record


def _summary(presenter, record: StepRecord) -> dict:
    """A finished run as plain JSON: status, parameters, the presenter's ranking value, measures."""
    out = {"status": record.status.value, "reason": record.reason, "iterations": record.iteration,
           "parameters": dict(record.parameters), "objective": presenter.ranking(record),
           "measures": record.to_json()["measures"],
           "meets_requirements": all(m.satisfied for m in record.measures)}
    out.update(presenter.summary(record))
    return out


def loop_signature(problem: Problem, parameters: dict) -> list[list[float]] | None:
    """The open loop GH of every condition at SIGNATURE_POINTS grid frequencies,
    as (re, im) pairs, at a run's final parameters: two runs with the same
    loop are the same optimum whatever their parameters (a lead-lag pair
    with its time constants swapped is one design).  None when a loop
    cannot be evaluated."""
    grid = problem.grid.omega[problem.grid.omega > 0]
    omega = grid[np.unique(np.linspace(0, grid.size - 1, SIGNATURE_POINTS).astype(int))]
    signature = []
    for k, condition in enumerate(problem.conditions):
        try:
            gh = open_loop(condition.network, condition.break_at, omega, problem.condition_values(k, named=parameters),
                           sensitivities=False).value
        except EngineError:
            return None
        signature += [[float(g.real), float(g.imag)] for g in gh]
    return signature


def _announce(index: int) -> str:
    """Log 'job started' on the scheduler (to count retries); the worker's address."""
    try:
        from distributed import get_worker
        worker = get_worker()
    except (ImportError, ValueError):
        return "local"
    worker.log_event(EVENT_TOPIC, {"index": index, "worker": worker.address})
    return worker.address


# -- execution ---------------------------------------------------------------

@dataclass
class Outcome:
    """Every run's result, in job order, and what happened to the workers."""

    runs: list[dict]
    workers: int
    attempts: dict[int, list[str]] = field(default_factory=dict)
    cancelled: bool = False


def execute(jobs: Sequence, scheduler: str | None = None, workers: int | None = None,
            progress: Callable[[int, int], None] | None = None,
            cancelled: Callable[[], bool] = lambda: False, client=None) -> Outcome:
    """Run the jobs on Dask: ``client`` if given, else a local cluster (one process
    per core, one thread each) or the cluster at ``scheduler``."""
    if client is not None:
        return _gather(client, jobs, progress, cancelled)
    from distributed import Client, LocalCluster
    cluster = None
    try:
        if scheduler:
            client = Client(scheduler, timeout="20s")
        else:
            cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=40)
            client = Client(cluster)
    except (OSError, TimeoutError) as exc:
        raise SessionError(f"cannot reach the Dask scheduler {scheduler or '(local)'}: {exc}") from None
    try:
        return _gather(client, jobs, progress, cancelled)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _gather(client, jobs, progress, cancelled) -> Outcome:
    from distributed import as_completed
    tag = uuid.uuid4().hex[:8]
    futures = client.map(run_job, [job.payload() for job in jobs], key=[f"loopcraft-{tag}-{j.index}" for j in jobs],
                         pure=False, retries=1)
    index_of = {f.key: j.index for f, j in zip(futures, jobs)}
    runs: dict[int, dict] = {}
    stopped = False
    for future in as_completed(futures):
        k = index_of[future.key]
        try:
            runs[k] = future.result()
        except Exception as exc:  # noqa: BLE001 - a lost worker or a cancelled job is recorded, not raised
            runs[k] = _lost(jobs[k], exc)
        if progress:
            progress(len(runs), len(jobs))
        if not stopped and cancelled():
            stopped = True
            client.cancel([f for f in futures if not f.done()])
    workers = len(client.scheduler_info().get("workers", {}))
    attempts: dict[int, list[str]] = {}
    for _, event in client.get_events(EVENT_TOPIC):
        if isinstance(event, dict) and event.get("index") in runs:
            attempts.setdefault(event["index"], []).append(event["worker"])
    for k, run in runs.items():
        run["attempts"] = len(attempts.get(k, [])) or (0 if run["status"] == "failed" else 1)
    return Outcome([runs[j.index] for j in jobs], workers, attempts, stopped)


def _lost(job, exc: BaseException) -> dict:
    kind = type(exc).__name__
    reason = "cancelled" if kind == "CancelledError" else f"{kind}: {exc}"
    return {"index": job.index, "label": job.label, "start": job.start, "worker": None, "status": "failed",
            "reason": reason, "parameters": {}, "objective": None, "measures": [], "meets_requirements": False,
            "iterations": 0, "seconds": None}


def execute_serial(jobs: Sequence, progress: Callable[[int, int], None] | None = None) -> Outcome:
    """The same jobs in this process, one after the other (the throughput baseline)."""
    runs = []
    for job in jobs:
        runs.append(run_job(job.payload()))
        runs[-1]["attempts"] = 1
        if progress:
            progress(len(runs), len(jobs))
    return Outcome(runs, 1, {})

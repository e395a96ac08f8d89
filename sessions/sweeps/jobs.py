"""Sweep jobs on a Dask worker, and running a sweep's jobs.

What is shipped to a worker is data only: the session's JSON document (its
CSV tables inlined, so a remote worker needs no files) and a job number; the
worker runs `run_job`, a function of this module that workers import (they
need loopcraft installed), and sends back plain JSON (the final StepRecord's
content, summarized by the algorithm's presenter).  Without an address a
local cluster is started with one process per core, one thread each; with
``tcp://HOST:PORT`` (checked before anything starts) that cluster is used,
reached within a connect timeout; a cluster named in Dask's configuration (a
batch system's, through dask-jobqueue: `sessions.sweeps.named_clusters`) is
started and scaled adaptively.  Short runs go to the workers in batches sized
from the first runs' times, so that 100 000 samples do not become 100 000
tasks; a tolerance study's samples go in chunks evaluated on the study's
problem built once per worker (`sessions.sweeps.study_chunks`).  Every failure to start or reach a cluster
is a `SessionError`.  Ctrl-C stops a sweep: the runs not finished are
cancelled and the finished ones kept (the local workers ignore it, started
with SIGINT ignored, so that only this process sees it).

A job that fails (a singular matrix, a worker that dies twice) is recorded
as failed with its reason; the sweep goes on.  Each job logs a "started"
event on the scheduler, so a job that had to be restarted on another worker
is reported with its attempts.
"""

from __future__ import annotations

import math
import os
import time
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import CancelledError as FutureCancelled
from contextlib import nullcontext
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.responses import open_loop
from engine.stepping.driver import first_record, iterate
from engine.stepping.presenter import Presenter, tolerant
from engine.stepping.protocol import Stepper, StepRecord
from sessions.build import build_problem
from sessions.errors import SessionError, in_words
from sessions.lifecycle import bind
from sessions.store import validated_model
from sessions.sweeps.cluster import (
    DEFAULT_CONNECT_TIMEOUT,
    Connection,
    InTurn,
    close,
    connect,
    connect_timeout,
    scheduler_address,
    sigint_ignored,
)
from sessions.sweeps.dispersion import CANCELLED, Tally
from sessions.sweeps.named_clusters import NamedCluster, connect_named

MAX_ITERATIONS = 1000
EVENT_TOPIC = "loopcraft-sweep"
SIGNATURE_POINTS = 24  # frequencies (grid points spread over the grid) of a run's loop signature


def run_job(payload: dict) -> dict:
    """Run (or evaluate) one job; never raises: a failure is a result."""
    began = time.perf_counter()
    worker = announce({"index": payload["index"]})
    result = {"index": payload["index"], "label": payload["label"], "start": payload["start"], "worker": worker}
    try:
        model = validated_model(payload["model"])
        problem = build_problem(model.problem, Path.cwd())
        registration, stepper = bind(model.algorithm, problem)
        if payload["mode"] == "evaluate":
            record = _evaluate(registration.presenter, stepper)
        else:
            last = deque(iterate(stepper, max_iter=MAX_ITERATIONS), maxlen=1)
            if not last:
                raise SessionError("the algorithm made no iteration")
            record = last[0][1]
        result.update(_summary(registration.presenter, record))
        if payload["mode"] != "evaluate":
            result["signature"] = loop_signature(problem, record.parameters)
    except Exception as exc:  # noqa: BLE001 - a run's failure is data, never the sweep's end
        result.update(
            status="failed",
            reason=in_words(exc),
            parameters={},
            ranking=None,
            measures=[],
            meets_requirements=False,
            iterations=0,
        )
    result["seconds"] = time.perf_counter() - began
    return result


def run_batch(payloads: list[dict]) -> list[dict]:
    """`run_job` of each payload in turn (short runs go to a worker together: `batch_size`)."""
    return [run_job(payload) for payload in payloads]


def _evaluate(presenter: Presenter, stepper: Stepper) -> StepRecord:
    """The tableau of the design as it is: iteration 0's record, as the presenter gives it."""
    record = first_record(presenter, stepper)
    if record is None:
        raise SessionError("the design's tableau cannot be computed")
    return record


def _summary(presenter, record: StepRecord) -> dict:
    """A finished run as plain JSON: status, parameters, the presenter's ranking value, measures."""
    out = {
        "status": record.status.value,
        "reason": record.reason,
        "iterations": record.iteration,
        "parameters": dict(record.parameters),
        "ranking": tolerant(lambda: presenter.ranking(record), lambda: record.objective),
        "measures": record.to_json()["measures"],
        "meets_requirements": all(m.satisfied for m in record.measures),
    }
    out.update(tolerant(lambda: presenter.summary(record), dict))
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
            gh = open_loop(
                condition.network,
                condition.break_at,
                omega,
                problem.condition_values(k, named=parameters),
                sensitivities=False,
            ).value
        except EngineError:
            return None
        signature += [[float(g.real), float(g.imag)] for g in gh]
    return signature


def announce(started: dict) -> str:
    """Log what started (a job's index, or a chunk's task) on the scheduler, to count retries;
    the worker's address ("local" outside a worker)."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        return "local"
    worker.log_event(EVENT_TOPIC, {**started, "worker": worker.address})
    return worker.address


# -- execution ---------------------------------------------------------------

RESULT_WAIT = 5.0  # s: for a finished run's result after an interrupt


@dataclass
class Outcome:
    """Every run's result, in job order, and what happened to the workers;
    ``interrupted``: Ctrl-C stopped it (the runs not finished are cancelled)."""

    runs: list[dict]
    workers: int
    attempts: dict[int, list[str]] = field(default_factory=dict)
    cancelled: bool = False
    interrupted: bool = False
    note: str = ""  # why the runs went serially rather than on a local cluster, or in batches
    serial: bool = False  # the runs were made in this process, one after the other
    # a tolerance study's outputs gathered as its runs were made (``runs``: the ones it kept, `Tally`)
    tally: Tally | None = None
    given_up: str = ""  # why the cluster's runs left were not computed (`sessions.sweeps.cluster.InTurn`)
    # a study's chunks on a cluster (`sessions.sweeps.study_chunks`): each one's samples and the CPU seconds
    # its worker spent evaluating them (the batch's own, Dask's work on the worker apart)
    chunks: tuple[tuple[int, float], ...] = ()

    @property
    def finished(self) -> int:
        """How many runs ran to their end (not cancelled)."""
        if self.tally is not None:
            return self.tally.finished
        return sum(r["reason"] != CANCELLED for r in self.runs)


def execute(
    jobs: Sequence,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    cancelled: Callable[[], bool] = lambda: False,
    client=None,
    timeout: float = DEFAULT_CONNECT_TIMEOUT,
    cluster: NamedCluster | None = None,
) -> Outcome:
    """Run the jobs on Dask: ``client`` if given, else a local cluster (one process
    per core, one thread each), the cluster at ``scheduler`` (tcp://HOST:PORT,
    reached within ``timeout`` seconds) or a ``cluster`` named in Dask's configuration
    (`sessions.sweeps.named_clusters`).  With none of ``scheduler``, ``workers`` and
    ``cluster`` given, a tolerance study that can be is evaluated here as a batch
    (`batch_here`); otherwise the first run (or two) is made and timed here: the rest run here
    too when a local cluster could not pay for its start-up.  Otherwise the first
    `FIRST_PER_WORKER` runs per worker are timed on the cluster, one to a task.  Runs
    shorter than `BATCH_SECONDS` then go to the workers in batches (`batch_size`); the
    outcome's ``note`` says which.  A tolerance study that `batch_study` evaluates on its
    problem built once goes in chunks of samples instead (`sessions.sweeps.study_chunks`).
    Ctrl-C stops it: the finished runs are kept."""
    if client is not None:
        return _gather(client, jobs, progress, cancelled)
    address, here = scheduler_address(scheduler), []
    if address is None and workers is None and cluster is None and jobs:  # a local cluster: maybe not worth it
        # a batch in this process outruns a local cluster of single runs (a study evaluated per loop does not)
        batched = batch_here(jobs, progress, unbatched=False)
        if batched is not None:
            return batched
        here, each, serial = _first_here(jobs, progress)
        if serial is not None:
            return serial
    from sessions.sweeps.batch_study import applies  # (it imports this module)

    chunked = applies(jobs)  # a tolerance study: its samples go in chunks to workers that build its problem once
    wait = connect_timeout(timeout)
    connection = connect(address, workers, wait) if cluster is None else connect_named(cluster, workers, wait)
    try:
        if chunked:
            from sessions.sweeps.study_chunks import run_chunked

            return run_chunked(connection, jobs[len(here) :], progress, cancelled, made=here)
        if not here:
            return _timed_on_cluster(connection, jobs, progress, cancelled)
        return _rest_batched(connection, jobs, Outcome(here, 1), each, progress, cancelled)
    finally:
        with sigint_ignored():
            close(connection.client, connection.cluster)


LOCAL_CLUSTER_START = 3.0  # s: a local cluster's start-up and first imports, measured on 2 cores
BATCH_SECONDS = 0.25  # s: runs shorter than this go to a worker together, about this much work at a time
BATCHES_PER_WORKER = 4  # ... but in at least this many batches per worker (none idles long at the end)
SECOND_TIMING = 1.0  # s: a first run at most this long is timed again on the second (its imports)
FIRST_PER_WORKER = 2  # runs per worker timed on a cluster, one to a task, before the rest are batched


def batch_size(each: float, count: int, workers: int) -> int:
    """How many runs of about ``each`` seconds go to a worker together: about
    `BATCH_SECONDS` of work (a Dask task costs a few ms of its own: 2 ms runs went
    no faster on two workers than serially), in at least `BATCHES_PER_WORKER`
    batches per worker."""
    by_time = int(BATCH_SECONDS / each) if each > 0 else count
    by_balance = count // (BATCHES_PER_WORKER * max(workers, 1))
    return max(1, min(by_time, by_balance))


def _timed_on_cluster(connection: Connection, jobs: Sequence, progress, cancelled) -> Outcome:
    """The first `FIRST_PER_WORKER` runs per worker one to a task, timed on the workers
    (the shortest counts: a worker's first run pays for its imports); the rest in
    batches sized from them."""
    workers = max(connection.workers, worker_count(connection.client))
    count = min(len(jobs), FIRST_PER_WORKER * workers)
    first = _gather(connection.client, jobs[:count], _shifted(progress, 0, len(jobs)), cancelled)
    if first.cancelled or first.given_up or count == len(jobs):
        rest = [
            {**lost_run(job, None), **({"reason": first.given_up} if first.given_up else {})} for job in jobs[count:]
        ]
        return replace(first, runs=first.runs + rest)
    timed = [r["seconds"] for r in first.runs if r["status"] != "failed" and r["seconds"] is not None]
    return _rest_batched(connection, jobs, first, min(timed, default=math.inf), progress, cancelled)


def _rest_batched(connection: Connection, jobs: Sequence, first: Outcome, each: float, progress, cancelled) -> Outcome:
    """The jobs after the ``first`` ones, in batches of runs of about ``each`` seconds (`batch_size`)."""
    done = len(first.runs)
    workers = max(connection.workers, worker_count(connection.client))
    size = batch_size(each, len(jobs) - done, workers)
    rest = _gather(connection.client, jobs[done:], _shifted(progress, done, len(jobs)), cancelled, size)
    note = f"runs of about {each:.2g} s sent to the workers {size} at a time" if size > 1 else ""
    note = "; ".join(text for text in (note, rest.note) if text)
    attempts = {**first.attempts, **rest.attempts}
    runs = first.runs + rest.runs
    return replace(rest, runs=runs, workers=computed_by(runs, attempts), attempts=attempts, note=note)


def _shifted(progress: Callable[[int, int], None] | None, offset: int, total: int):
    """A progress report of ``total`` runs from one of the runs after the first ``offset``."""
    return None if progress is None else lambda k, _: progress(k + offset, total)


def worker_count(client) -> int:
    try:
        return len(client.scheduler_info().get("workers", {})) or 1
    except Exception:  # noqa: BLE001 - a scheduler that cannot say: batches sized for one worker
        return 1


def _first_here(
    jobs: Sequence, progress: Callable[[int, int], None] | None
) -> tuple[list[dict], float, Outcome | None]:
    """Run the first job here and time it (and the second, when the first took at most
    `SECOND_TIMING`); when the rest would take less than a local cluster of one process
    per core saves (or there is one core), run them here too: (the runs made here,
    the shortest one's time, the serial outcome or None)."""
    n = os.cpu_count() or 1
    here = []
    for job in jobs[:2]:  # a second when the first was short: the first pays for imports made on first use
        if here and here[0]["seconds"] > SECOND_TIMING:
            break
        here.append(run_job(job.payload()))
        here[-1]["attempts"] = 1
        if progress:
            progress(len(here), len(jobs))
    each = min(run["seconds"] for run in here)
    estimate = each * (len(jobs) - len(here))
    if n > 1 and estimate * (1 - 1 / n) <= LOCAL_CLUSTER_START:
        note = (
            f"serial: the {len(jobs) - len(here)} other run(s) take about {estimate:.2g} s here, less than "
            f"a local cluster's start-up ({LOCAL_CLUSTER_START:g} s) would save"
        )
    elif n == 1:
        note = "serial: one core"
    else:
        return here, each, None
    rest = execute_serial(jobs[len(here) :], progress, made=here)
    note = "; ".join(text for text in (note, rest.note) if text)
    return here, each, replace(rest, note=note)


def _gather(client, jobs, progress, cancelled, size: int = 1, task: Callable = run_batch) -> Outcome:
    """The jobs on the cluster, ``size`` to a task (``task``: `run_batch` or a stand-in);
    a batch whose task fails (its worker died under it) is sent again one run to a
    task, so that a run that kills its worker does not take the others with it."""
    tag = uuid.uuid4().hex[:8]
    tasks = _submit(client, task, [list(jobs[k : k + size]) for k in range(0, len(jobs), size)], tag)
    runs: dict[int, dict] = {}
    retired: dict[str, list] = {}  # the key of a batch sent again one run to a task -> its batch
    stopped = interrupted = False
    waiting = InTurn(client, tasks)
    try:
        for future, result in waiting:
            batch = tasks[future]
            if len(batch) > 1 and future.status == "error" and not stopped and not cancelled():
                alone = _submit(client, task, [[job] for job in batch], tag, "-alone")
                retired[future.key] = batch
                del tasks[future]
                tasks.update(alone)
                waiting.update(list(alone))
                continue
            runs.update(zip((job.index for job in batch), _results(result, batch)))
            if progress:
                progress(len(runs), len(jobs))
            if not stopped and cancelled():
                stopped = True
                client.cancel([f for f in tasks if not f.done()])
    except KeyboardInterrupt:
        with sigint_ignored():
            stopped = interrupted = True
            _interrupted(client, tasks, runs)
    if waiting.given_up and not interrupted:
        _given_up(client, tasks, runs, waiting.given_up)
    keys: dict[int, list[str]] = {}  # run index -> the keys of the tasks it was in
    for future, batch in tasks.items():
        for job in batch:
            keys.setdefault(job.index, []).append(future.key)
    for key, batch in retired.items():
        for job in batch:
            keys.setdefault(job.index, []).append(key)
    with sigint_ignored() if interrupted else nullcontext():
        workers, attempts = _workers_and_attempts(client, runs, keys)
    lost = sum(runs[j.index]["reason"] == waiting.given_up for j in jobs) if waiting.given_up else 0
    note = f"{waiting.given_up}: {lost} run(s) recorded as failed" if lost else ""
    return Outcome([runs[j.index] for j in jobs], workers, attempts, stopped, interrupted, note, given_up=note)


def _submit(client, task: Callable, batches: list[list], tag: str, suffix: str = "") -> dict:
    """One Dask task per batch (retried once when it raises), keyed by its first job:
    each task's future -> its batch of jobs."""
    futures = client.map(
        task,
        [[job.payload() for job in batch] for batch in batches],
        key=[f"loopcraft-{tag}-{batch[0].index}{suffix}" for batch in batches],
        pure=False,
        retries=1,
    )
    return dict(zip(futures, batches))


def _results(result, batch: list) -> list[dict]:
    """A finished batch's runs (``result``: its task's, or the exception it raised: a lost worker
    or a cancelled batch is recorded, not raised)."""
    if isinstance(result, BaseException):
        return [lost_run(job, result) for job in batch]
    return result


def _interrupted(client, tasks: dict, runs: dict[int, dict]) -> None:
    """After Ctrl-C: cancel what has not finished, keep what has (``tasks``: future -> its batch)."""
    try:
        client.cancel([f for f in tasks if not f.done()])
    except Exception:  # noqa: BLE001, S110 - the runs are kept whatever the scheduler says
        pass
    for future, batch in tasks.items():
        if all(job.index in runs for job in batch):
            continue
        results = None
        if future.status == "finished":
            try:
                results = future.result(timeout=RESULT_WAIT)
            except Exception:  # noqa: BLE001, S110 - not fetched in time: cancelled like the rest
                pass
        for k, job in enumerate(batch):
            runs.setdefault(job.index, results[k] if results else lost_run(job, None))


def _given_up(client, tasks: dict, runs: dict[int, dict], why: str) -> None:
    """The wait given up (`InTurn`): the batches not finished cancelled, their runs failed for ``why``."""
    try:
        client.cancel([f for f in tasks if not f.done()])
    except Exception:  # noqa: BLE001, S110 - the runs are recorded whatever the scheduler says
        pass
    for batch in tasks.values():
        for job in batch:
            runs.setdefault(job.index, {**lost_run(job, None), "reason": why})


def _workers_and_attempts(
    client, runs: dict[int, dict], keys: dict[int, list[str]]
) -> tuple[int, dict[int, list[str]]]:
    """How many workers computed the runs, and where each run was started: its attempts are
    the times the scheduler sent its tasks (``keys``) to a worker, read from the scheduler's
    transition log (a finished batch whose results died with its worker is sent again), its
    workers those its starts' events name (a worker killed before its events reached the
    scheduler is named "a lost worker")."""
    try:
        events, sent = starts_and_sends(client, sorted({key for k in runs for key in keys.get(k, [])}))
    except Exception:  # noqa: BLE001 - a scheduler gone by now: the runs are kept without
        events, sent = (), {}
    started: dict[int, list[str]] = {}
    for _, event in events:
        if isinstance(event, dict) and event.get("index") in runs:
            started.setdefault(event["index"], []).append(event["worker"])
    attempts: dict[int, list[str]] = {}
    for k, run in runs.items():
        named = started.get(k, [])
        count = max(len(named), sum(sent.get(key, 0) for key in keys.get(k, [])))
        run["attempts"] = count or (0 if run["status"] == "failed" else 1)
        if count:
            attempts[k] = named + [LOST_WORKER] * (count - len(named))
    return computed_by(runs.values(), attempts), attempts


LOST_WORKER = "a lost worker"  # a start whose worker died before its event reached the scheduler


def computed_by(runs: Iterable[dict], attempts: dict[int, list[str]]) -> int:
    """How many workers are known to have computed runs: those that finished one, and those
    its starts were logged on (a worker killed midway among them)."""
    finished = {r["worker"] for r in runs if r["status"] != "failed" and r.get("worker")}
    started = {w for workers in attempts.values() for w in workers}
    return len((finished | started) - {LOST_WORKER})


def starts_and_sends(client, keys: list[str]) -> tuple[tuple, dict[str, int]]:
    """The starts logged on the scheduler (`announce`: its events of `EVENT_TOPIC`) and how many
    times it sent each task to a worker (its transitions to 'processing' in its own log), read
    there in one call at the study's end (two were two waits on the scheduler after the last
    result; run there: the scheduler needs no loopcraft)."""

    def read(dask_scheduler, topic: str, keys: list[str]) -> tuple[tuple, dict[str, int]]:
        wanted, counts = set(keys), dict.fromkeys(keys, 0)
        if wanted:
            for transition in dask_scheduler.transition_log:
                if transition[0] in wanted and transition[2] == "processing":
                    counts[transition[0]] += 1
        return tuple(dask_scheduler.get_events(topic)), counts

    return client.run_on_scheduler(read, topic=EVENT_TOPIC, keys=keys)


def lost_run(job, exc: BaseException | None) -> dict:
    """A run that did not finish: ``exc`` None or a cancelled future's error (Dask's
    FutureCancelledError is one) for a cancelled one."""
    reason = CANCELLED if exc is None or isinstance(exc, FutureCancelled) else in_words(exc)
    return {
        "index": job.index,
        "label": job.label,
        "start": job.start,
        "worker": None,
        "status": "failed",
        "reason": reason,
        "parameters": {},
        "ranking": None,
        "measures": [],
        "meets_requirements": False,
        "iterations": 0,
        "seconds": None,
    }


def batch_here(
    jobs: Sequence, progress: Callable[[int, int], None] | None = None, unbatched: bool = True
) -> Outcome | None:
    """A tolerance study's samples evaluated as a batch in this process (`sessions.sweeps.batch_study`:
    its note says which went the per-loop path, and why a study is not batched), gathered as they
    are made (`Tally.of_study`); None when the jobs are not such a study, or, without ``unbatched``,
    when its samples would all go per loop."""
    from sessions.sweeps.batch_study import batch_runs  # (it runs the samples it leaves with run_job)

    tally = Tally.of_study(len(jobs))
    batch = batch_runs(jobs, progress, tally, unbatched)
    if batch is None:
        return None
    for job in jobs[batch.done :]:
        tally.add(lost_run(job, None))
    note = "; ".join(text for text in (batch.note, tally.note) if text)
    return Outcome(tally.runs(), 1, {}, batch.interrupted, batch.interrupted, note, serial=True, tally=tally)


def execute_serial(
    jobs: Sequence, progress: Callable[[int, int], None] | None = None, made: Sequence[dict] = ()
) -> Outcome:
    """The same jobs in this process, one after the other (the throughput baseline);
    Ctrl-C stops it: the finished runs are kept, the rest cancelled.  A tolerance study
    that can be is evaluated by `sessions.sweeps.batch_study` (as a batch, or per loop on its
    problem built once: its note says which samples went the per-loop path, and why a study is
    not batched); its runs are gathered as they are made (`Tally.of_study`).  ``made``: the runs
    of jobs before these, made already (they come first)."""
    if not made:
        batched = batch_here(jobs, progress)
        if batched is not None:
            return batched
    tolerance = len(jobs) > 0 and getattr(jobs[0], "mode", None) == "evaluate"  # a tolerance study's samples
    tally = Tally.of_study(len(made) + len(jobs)) if tolerance else None
    runs: list[dict] = []
    keep = runs.append if tally is None else tally.add
    for run in made:
        keep(run)
    done, total = len(made), len(made) + len(jobs)
    try:
        for job in jobs:
            run = run_job(job.payload())
            run["attempts"] = 1
            keep(run)
            done += 1
            if progress:
                progress(done, total)
    except KeyboardInterrupt:
        for job in jobs[done - len(made) :]:
            keep(lost_run(job, None))
        kept = runs if tally is None else tally.runs()
        return Outcome(kept, 1, {}, cancelled=True, interrupted=True, serial=True, tally=tally)
    if tally is None:
        return Outcome(runs, 1, {}, serial=True)
    return Outcome(tally.runs(), 1, {}, note=tally.note, serial=True, tally=tally)

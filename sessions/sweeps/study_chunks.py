"""A tolerance study on a Dask cluster in chunks of samples: what a task is sent is a consecutive
range of the study's planned samples (`ToleranceSamples.shipped`: the study's document and the
range's drawn deviations, never a document per sample); the worker builds the study's problem
once (`sessions.sweeps.batch_study.chunk_runs` keeps it under the study's key for its next
chunks) and evaluates the chunk as the serial study does (batched, or per loop on the problem
built once); the chunk's runs come back as arrays (`Records`), a run made only for a sample the
study keeps, and go to the study's `Tally` in sample order.

The first chunks, a probe per worker (two for one worker), are small (`FIRST_CHUNK` samples and
`PROBE_RATIO` times that, each part timed apart on the worker: two sizes in one task) and timed
in CPU seconds (the evaluating thread's, the problem's building apart: a loaded machine's waits
are not work); the later ones are sized from them to about `CHUNK_SECONDS` of work, a chunk's
fixed cost told from a sample's, at least `CHUNKS_PER_WORKER` per worker, the last ones equal
(`_Sizes`): few tasks, since each costs tens of ms of CPU besides its samples.  On a cluster
started here (all its workers there from the start) the probe goes on into its worker's share of
the study, in the same task: the worker evaluates of the share what its probe's parts say fits in
`CHUNK_SECONDS` (`fitting`), and what it leaves is sent again first, sized from the parts timed;
a study that fits takes one task a worker, with no round trip between a probe and its chunk.  A
chunk whose task fails (its worker died more often than Dask allows) is sent again as two
halves, down to single samples: a sample that kills its worker does not take the others with
it, and the splitting ends.  The bookkeeping is the scheduler's: each chunk logs its start
(`announce`), the times each task was sent to a worker are read from the scheduler's
transition log (`starts_and_sends`, with the starts: one call at the end), and ``workers``
counts the workers that finished a chunk or started one."""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable, Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field, replace

import numpy as np

from sessions.sweeps.batch_study import BatchOutcome, ChunkRuns, chunk_runs, study_key
from sessions.sweeps.cluster import Connection, InTurn, sigint_ignored
from sessions.sweeps.dispersion import Tally
from sessions.sweeps.jobs import (
    LOST_WORKER,
    RESULT_WAIT,
    Outcome,
    announce,
    lost_run,
    starts_and_sends,
    worker_count,
)
from sessions.sweeps.plan import ToleranceSamples
from sessions.sweeps.records import Records

FIRST_CHUNK = 100  # samples in a probe's first part, timed on its worker
# ... its second part this many times larger: the slope from 100 and 200 samples (12 ms of fixed cost, 60 us a
# sample) was 6 ms of a loaded machine's noise, and sized the lag-lead's chunks to 3234 samples as often as 4850
PROBE_RATIO = 4
# A chunk costs about 30 ms of CPU besides its samples (the batch's fixed cost, 12 ms of the lag-lead's, and
# Dask's: the scheduler and the client in the main process, the task on its worker).  20 000 lag-lead
# samples on 2 workers took 13 chunks at 0.25 s and 4 a worker: 1.46-1.64 s of the workers' CPU, 0.16-0.18 s
# of the main process's; 9 chunks at these: 1.39-1.42 s and 0.12-0.13 s (interleaved, load 3.4-3.7); 6 with a
# probe per worker timing two sizes: 1.28-1.34 s and 0.07-0.08 s (c0189aa's 9-10: 1.35-1.41, 0.11-0.12; load 1.6-3.5)
# With the probes, a cluster started here (all its workers there from the start) takes its study in one chunk per
# worker when a chunk of CHUNK_SECONDS holds it: 20 000 lag-lead samples on 2 local workers in 4 tasks (500, 500,
# 9500, 9500), not 6 (4 x 4750 after the probes at 0.5 s and two a worker): this process's CPU 0.098-0.134 s against
# 0.127-0.175 (lower in each of 6 interleaved pairs, medians 0.121 and 0.147; load 2.7-2.9), the workers' the same
# (the batch evaluates 5000 samples at a time: as many evaluations), and no wait between two chunks on a worker
CHUNK_SECONDS = 1.0  # s of work a chunk is sized to
# A worker's share in the first round on a cluster whose workers are all there (`_Sizes.ahead`) at most: the
# samples shipped with its probe, of which it evaluates what fits in CHUNK_SECONDS (50 000 samples' draws of
# 4 parameters: 1.6 MB; the lag-lead's second on a worker is about 25 000 samples)
FIRST_SHARE = 50_000
CHUNKS_PER_WORKER = 2  # ... in at least this many chunks per worker (the last ones equal) on a cluster that may grow
# A worker goes on to the end of its share when what it would leave is at most this fraction of what fits in
# CHUNK_SECONDS: seen at load 4.4, a worker left 312 of 10 000 lag-lead samples, sent as 2 chunks of 156
SLACK = 0.25
IN_FLIGHT = 2  # chunks sent per worker at a time: the next one waits on the worker while the main process sizes another


@dataclass
class _Sizes:
    """The study's chunks (ranges of positions).  The first round, a probe per worker (at least
    two), each of `FIRST_CHUNK` samples and `PROBE_RATIO` times that, timed apart on its worker (`chunk_runs`'s
    ``split``): two sizes tell a chunk's fixed cost from a sample's (least squares over every
    part timed) from the first probe back, and each later chunk is sized to
    about `CHUNK_SECONDS` of work with it, never smaller than one sized before (a small chunk's samples look slow: sized
    down from them, the chunks would shrink to nothing on a loaded machine), in at least
    ``per_worker`` chunks per worker (`CHUNKS_PER_WORKER`, so that a worker joining later finds
    one; 1 when every worker is there from the start); the samples left are split in equal chunks, as
    many for each worker, so that the workers finish together and no chunk at the end is
    small (nor any smaller than a probe's second part: a few samples left go in one chunk).  With
    every worker there from the start, a worker's probe goes on into its share of the study
    (`ahead`): the first round is a share per worker, and each worker evaluates of it what its
    probe's parts say fits in `CHUNK_SECONDS` (all of it when the rest is within `SLACK` of that);
    what it leaves is ``given_back`` and sent first."""

    count: int
    workers: int
    per_worker: int = CHUNKS_PER_WORKER  # chunks a worker is sent at least (1: a cluster whose workers are all there)
    sent: int = 0
    timed: list[tuple[int, float]] = field(default_factory=list)  # (samples, CPU seconds) of each part timed
    sized: int = 0  # the largest size the timings asked for so far
    split: tuple[int, int] = (0, 0)  # the size asked for when the samples left were split, and their chunks' size
    returned: list[tuple[int, int]] = field(default_factory=list)  # ranges sent and given back unevaluated

    @property
    def first(self) -> int:
        """A probe's first part: the probes, a tenth of the study at most."""
        return max(1, min(FIRST_CHUNK, self.count // (2 * (1 + PROBE_RATIO) * CHUNKS_PER_WORKER * self.workers)))

    @property
    def ahead(self) -> bool:
        """Does a probe go on into its worker's share (every worker there from the start)?"""
        return self.per_worker == 1

    @property
    def left(self) -> int:
        """The samples not sent, or given back."""
        return self.count - self.sent + sum(b - a for a, b in self.returned)

    def first_round(self) -> list[tuple[int, int]]:
        probe = (1 + PROBE_RATIO) * self.first
        share = max(probe, min(math.ceil(self.count / self.workers), FIRST_SHARE)) if self.ahead else probe
        return [self._take(share) for _ in range(max(2, self.workers)) if self.sent < self.count]

    def give_back(self, start: int, stop: int) -> None:
        """A range a worker left of its share: sent again first."""
        if start < stop:
            self.returned.append((start, stop))

    def next(self, in_flight: int) -> tuple[int, int] | None:
        """The next chunk's range, sized from the parts timed so far; until two sizes are timed
        (the probes back untimed: failed, or sent again as halves), none while ``in_flight``
        chunks may still time one (a chunk sized from one size would be the odd one out of the
        equal chunks after it, and one worker's share the larger), else one of a probe's second
        part's size."""
        if len({n for n, _ in self.timed}) < 2:
            return None if in_flight else self._take(PROBE_RATIO * self.first)
        target = self._target()
        if target != self.split[0]:  # the samples left split anew, in equal chunks, as many per worker
            chunks = math.ceil(math.ceil(self.left / target) / self.workers) * self.workers
            chunks = max(1, min(chunks, self.left // (PROBE_RATIO * self.first)))  # none smaller than a probe's part
            self.split = (target, math.ceil(self.left / chunks))
        return self._take(self.split[1])

    def _target(self) -> int:
        most = max(self.first, self.count // (self.per_worker * self.workers))
        per_sample, fixed = np.polyfit(*zip(*self.timed), 1)
        wanted = (CHUNK_SECONDS - max(fixed, 0.0)) / per_sample if per_sample > 0 and fixed < CHUNK_SECONDS else most
        self.sized = max(self.sized, min(int(wanted), most))
        return max(self.first, self.sized)

    def _take(self, size: int) -> tuple[int, int]:
        if self.returned:  # a range given back first, whole or its beginning
            start, stop = self.returned[0]
            size = max(1, min(size, stop - start))
            self.returned[0] = (start + size, stop)
            if start + size == stop:
                self.returned.pop(0)
            return start, start + size
        size = max(1, min(size, self.count - self.sent))
        self.sent += size
        return self.sent - size, self.sent


def fitting(timed: Sequence[tuple[int, float]], seconds: float) -> int:
    """How many more samples fit in ``seconds`` of work after the parts ``timed`` (samples, CPU
    seconds; two sizes at least): their fixed cost told from a sample's by the first two."""
    (n1, t1), (n2, t2) = timed[:2]
    spent = sum(t for _, t in timed)
    per_sample = (t2 - t1) / (n2 - n1) if n2 != n1 else 0.0
    if per_sample <= 0:  # within the noise: every second of the parts counted as the samples'
        per_sample = spent / max(n1 + n2, 1)
    fixed = max(t1 - per_sample * n1, 0.0)
    return max(int((seconds - spent - fixed) / per_sample), 0) if per_sample > 0 else 0


def evaluate_chunk(
    key: str, samples: ToleranceSamples, task: str, split: int = 0, probe: int = 0
) -> tuple[str, ChunkRuns]:
    """On a worker: the chunk's start logged on the scheduler (as task ``task``), its samples
    evaluated on the study's problem built once (``key``: `study_key`; its first ``split`` timed
    apart: `chunk_runs`); (the worker's address, the chunk's runs, each naming the worker).  With
    ``probe`` (a worker's share, `_Sizes.ahead`): the first ``probe`` samples are the probe (its
    first ``split`` timed apart), then as many more as its parts say fit in `CHUNK_SECONDS` of work
    (`fitting`), the rest left (the runs' timed parts count the samples evaluated)."""
    worker = announce({"chunk": task})
    runs = chunk_runs(key, samples[:probe] if 0 < probe < len(samples) else samples, split)
    if 0 < probe < len(samples) and len(runs.timed) == 2:
        fits, rest = fitting(runs.timed, CHUNK_SECONDS), len(samples) - probe
        more = rest if rest <= fits * (1 + SLACK) else fits  # a small rest is not worth a chunk of its own
        if more:
            tail = chunk_runs(key, samples[probe : probe + more])
            runs = replace(
                runs,
                items=runs.items + tail.items,
                alone=runs.alone + tail.alone,
                by_search=runs.by_search + tail.by_search,
                timed=runs.timed + tail.timed,
            )
    items = [
        replace(item, worker=worker) if isinstance(item, Records) else {**item, "worker": worker} for item in runs.items
    ]
    return worker, replace(runs, items=items)


@dataclass
class _InOrder:
    """The chunks' runs added to the study's tally in sample order (chunks finish in any
    order; a chunk is a range of positions in the study's samples)."""

    samples: ToleranceSamples
    tally: Tally
    done: int = 0  # positions added so far
    waiting: dict[int, tuple[int, ChunkRuns | list[dict]]] = field(default_factory=dict)  # start -> (stop, runs)
    alone: list[int] = field(default_factory=list)
    by_search: list[int] = field(default_factory=list)
    unbatched: str = ""

    def add(self, start: int, stop: int, runs: ChunkRuns | list[dict]) -> None:
        self.waiting[start] = (stop, runs)
        while self.done in self.waiting:
            self._take(self.done)

    def finish(self) -> None:
        """Everything left, in order: the samples of no finished chunk as cancelled runs."""
        while self.done < len(self.samples):
            if self.done in self.waiting:
                self._take(self.done)
                continue
            stop = min((start for start in self.waiting if start > self.done), default=len(self.samples))
            for job in self.samples[self.done : stop]:
                self.tally.add(lost_run(job, None))
            self.done = stop

    def _take(self, start: int) -> None:
        stop, runs = self.waiting.pop(start)
        if isinstance(runs, ChunkRuns):
            for item in runs.items:
                if isinstance(item, Records):
                    self.tally.add_records(item)
                else:
                    self.tally.add(item)
            self.alone += runs.alone
            self.by_search += runs.by_search
            self.unbatched = self.unbatched or runs.unbatched
        else:
            for run in runs:
                self.tally.add(run)
        self.done = stop


@dataclass
class _Tasks:
    """The chunks sent: each task's future -> its range of positions, every task's key -> its
    range (those sent again as halves included), the workers that finished one."""

    client: object
    samples: ToleranceSamples
    study: str  # `study_key`
    task: Callable = evaluate_chunk  # (a stand-in in tests)
    tag: str = field(default_factory=lambda: uuid.uuid4().hex[:8])
    running: dict = field(default_factory=dict)
    ranges: dict[str, tuple[int, int]] = field(default_factory=dict)
    finished_on: set[str] = field(default_factory=set)

    def send(
        self, ranges: list[tuple[int, int]], split: int = 0, on: Sequence[str | None] = (), probe: int = 0
    ) -> list:
        """The chunks of these ranges sent, each one's first ``split`` samples timed apart
        (`chunk_runs`), or its first ``probe`` a probe going on into the rest (`evaluate_chunk`);
        ``on``: the worker each is sent to (None: where the scheduler puts it), loosely (elsewhere
        when that worker is gone)."""
        targets = list(on) or [None] * len(ranges)
        futures = []
        for worker in dict.fromkeys(targets):  # one call per worker named, in order
            mine = [r for r, target in zip(ranges, targets) if target == worker]
            keys = [
                f"loopcraft-{self.tag}-{self.samples.indices[a]}-{self.samples.indices[b - 1] + 1}" for a, b in mine
            ]
            sent = self.client.map(  # type: ignore[attr-defined]
                self.task,
                [self.study] * len(mine),
                [self.samples[a:b].shipped() for a, b in mine],
                keys,
                [split] * len(mine),
                *([[probe] * len(mine)] if probe else []),
                key=keys,
                pure=False,
                retries=1,
                **({"workers": [worker], "allow_other_workers": True} if worker else {}),
            )
            self.running.update(zip(sent, mine))
            self.ranges.update(zip(keys, mine))
            futures += sent
        return futures


def _one_each(ranges: list[tuple[int, int]], sizes: _Sizes, back: str | None, workers: list[str]) -> list[str | None]:
    """The workers a round of one chunk per worker goes to (``sizes.per_worker`` 1: the first
    round sized, sent as the first probe comes ``back``): the first chunk to that probe's worker
    (idle now), the others to the workers still on their probes.  Left to the scheduler, both
    chunks of 20 000 lag-lead samples on 2 workers were once put on one worker: the other sat idle
    0.76 s after its probe until Dask's work stealing moved the chunk (seen at load 3.1).  None
    (the scheduler's choice) for any other round."""
    if sizes.per_worker != 1 or back not in workers or len(ranges) != len(workers):
        return [None] * len(ranges)
    return [back] + [worker for worker in workers if worker != back]


def _addresses(client) -> list[str]:
    """The scheduler's workers' addresses ([] when it does not answer)."""
    try:
        return list(client.scheduler_info().get("workers", {}))
    except Exception:  # noqa: BLE001 - no chunk is sent to a named worker then
        return []


def run_chunked(
    connection: Connection,
    samples: ToleranceSamples,
    progress: Callable[[int, int], None] | None = None,
    cancelled: Callable[[], bool] = lambda: False,
    made: Sequence[dict] = (),
    task: Callable = evaluate_chunk,
) -> Outcome:
    """The study's samples on the cluster in chunks (module docstring), gathered in a `Tally`;
    ``made``: the runs of the samples before these, made already (they come first); ``task``:
    `evaluate_chunk` or a stand-in.  Ctrl-C or ``cancelled`` stops it: the finished chunks are
    kept, the rest cancelled."""
    client = connection.client
    # a cluster started here has the workers planned (never more): the scheduler is asked only of its own
    workers = connection.workers or worker_count(client)
    tally = Tally.of_study(len(made) + len(samples))
    for run in made:
        tally.add(run)
    gathered = _InOrder(samples, tally)
    tasks = _Tasks(client, samples, study_key(samples), task)
    sizes = _Sizes(len(samples), workers, 1 if connection.fixed else CHUNKS_PER_WORKER)
    every = _addresses(client) if sizes.ahead else []
    first = sizes.first_round()
    probe = (1 + PROBE_RATIO) * sizes.first if sizes.ahead else 0
    on = every if len(every) == len(first) else ()  # a share a worker, each to its own
    waiting = InTurn(client, tasks.send(first, split=sizes.first, on=on, probe=probe))
    timed: list[tuple[int, float]] = []  # each chunk's samples and CPU seconds
    stopped = interrupted = False
    try:
        for future, result in waiting:
            start, stop = tasks.running.pop(future)
            runs = _result(future, result, samples[start:stop], tasks)
            if runs is None and not stopped:  # its task failed: sent again as two halves
                middle = (start + stop) // 2
                waiting.update(tasks.send([(start, middle), (middle, stop)]))
                continue
            if isinstance(runs, ChunkRuns):
                sizes.timed += runs.timed
                stop = _evaluated(tasks, future.key, start, stop, runs, None if stopped else sizes)
                timed.append((stop - start, runs.cpu_seconds))
            if not stopped:  # the next chunks, sized from those timed
                ranges = _refill(sizes, len(tasks.running), IN_FLIGHT * workers)
                back = result[0] if isinstance(runs, ChunkRuns) else None
                waiting.update(tasks.send(ranges, on=_one_each(ranges, sizes, back, every)))
            gathered.add(
                start, stop, runs if runs is not None else [lost_run(job, None) for job in samples[start:stop]]
            )
            if progress:
                progress(len(made) + gathered.done, len(made) + len(samples))
            if not stopped and cancelled():
                stopped = True
                client.cancel([f for f in tasks.running if not f.done()])
    except KeyboardInterrupt:
        with sigint_ignored():
            stopped = interrupted = True
            _keep_finished(client, tasks, gathered)
    lost, not_computed = (
        _given_up(client, tasks, gathered, sizes, waiting.given_up) if waiting.given_up and not interrupted else ("", 0)
    )
    gathered.finish()
    with sigint_ignored() if interrupted else nullcontext():
        attempts, workers_seen = _attempts(client, tasks)
    computed = len((tasks.finished_on | workers_seen) - {LOST_WORKER})
    for run in tally.runs():
        if run["index"] in attempts:
            run["attempts"] = len(attempts[run["index"]])
    batch = BatchOutcome(
        [],
        len(samples) - not_computed,
        tuple(gathered.alone),
        tuple(gathered.by_search),
        interrupted,
        gathered.unbatched,
    )
    sent = [b - a for a, b in tasks.ranges.values()]
    how = "a share per worker, its probe's parts timed there" if sizes.ahead else "sized from a probe per worker"
    chunks = (
        f"samples sent to the workers in {len(tasks.ranges)} chunks of {min(sent)}-{max(sent)} "
        f"({how}, to about {CHUNK_SECONDS:g} s of work)"
    )
    note = "; ".join(text for text in (batch.note, chunks, lost, tally.note) if text)
    retried = {k: v for k, v in attempts.items() if len(v) > 1}
    return Outcome(
        tally.runs(),
        computed,
        retried,
        stopped,
        interrupted,
        note,
        tally=tally,
        given_up=lost,
        chunks=tuple(timed),
    )


def _evaluated(tasks: _Tasks, key: str, start: int, stop: int, runs: ChunkRuns, sizes: _Sizes | None) -> int:
    """Where the samples a chunk evaluated end (a share's probe leaves the rest, `evaluate_chunk`):
    its task's range cut there, what it left given back to ``sizes`` (None: sent no more)."""
    end = start + sum(n for n, _ in runs.timed)
    if end < stop:
        tasks.ranges[key] = (start, end)
        if sizes is not None:
            sizes.give_back(end, stop)
    return end


def _refill(sizes: _Sizes, running: int, most: int) -> list[tuple[int, int]]:
    """The chunks to send now, ``running`` in flight: up to ``most`` in flight while there are
    samples left and `_Sizes.next` sizes one."""
    ranges: list[tuple[int, int]] = []
    while sizes.left > 0 and running + len(ranges) < most:
        chunk = sizes.next(running + len(ranges))
        if chunk is None:
            break
        ranges.append(chunk)
    return ranges


def _given_up(client, tasks: _Tasks, gathered: _InOrder, sizes: _Sizes, why: str) -> tuple[str, int]:
    """The chunks still running when the wait was given up (`InTurn`) cancelled, their samples and
    those never sent recorded as failed, the reason ``why``: what the study's note says of them,
    and how many they are."""
    try:
        client.cancel(list(tasks.running))
    except Exception:  # noqa: BLE001, S110 - the samples are recorded whatever the scheduler says
        pass
    unsent = sizes.returned + ([(sizes.sent, sizes.count)] if sizes.sent < sizes.count else [])
    ranges = sorted(list(tasks.running.values()) + unsent)
    tasks.running.clear()
    for start, stop in ranges:
        gathered.add(start, stop, [{**lost_run(job, None), "reason": why} for job in gathered.samples[start:stop]])
    joined: list[list[int]] = []
    for start, stop in ranges:  # consecutive ranges named as one
        if joined and joined[-1][1] == start:
            joined[-1][1] = stop
        else:
            joined.append([start, stop])
    named = ", ".join(f"{gathered.samples.indices[a]}-{gathered.samples.indices[b - 1]}" for a, b in joined)
    count = sum(b - a for a, b in ranges)
    return f"{why}: samples {named} lost ({count} samples recorded as failed)", count


def _result(future, result, part: ToleranceSamples, tasks: _Tasks) -> ChunkRuns | list[dict] | None:
    """A finished chunk's runs (``result``: its task's, or the exception it raised); its samples'
    failed runs when its task failed for good (a single sample, or cancelled); None when it failed
    and is to be sent again as halves."""
    if isinstance(result, BaseException):  # a lost worker or a cancelled chunk is recorded, not raised
        if future.status == "error" and len(part) > 1:
            return None
        return [lost_run(job, result) for job in part]
    worker, runs = result
    tasks.finished_on.add(worker)
    return runs


def _keep_finished(client, tasks: _Tasks, gathered: _InOrder) -> None:
    """After Ctrl-C: cancel what has not finished, keep what has (fetched within `RESULT_WAIT`)."""
    try:
        client.cancel([f for f in tasks.running if not f.done()])
    except Exception:  # noqa: BLE001, S110 - the runs are kept whatever the scheduler says
        pass
    for future, (start, stop) in tasks.running.items():
        if future.status == "finished":
            try:
                worker, runs = future.result(timeout=RESULT_WAIT)
            except Exception:  # noqa: BLE001, S110 - not fetched in time: cancelled like the rest
                continue
            tasks.finished_on.add(worker)
            gathered.add(start, _evaluated(tasks, future.key, start, stop, runs, None), runs)


def _attempts(client, tasks: _Tasks) -> tuple[dict[int, list[str]], set[str]]:
    """Where each sample was started, for the samples started more than once or in a chunk sent
    again as halves (sample index -> workers; a start whose event never reached the scheduler
    is `LOST_WORKER`'s), and every worker a chunk's start names.  A chunk's starts are the
    times the scheduler sent its task to a worker (its transition log)."""
    try:
        events, sent = starts_and_sends(client, list(tasks.ranges))
    except Exception:  # noqa: BLE001 - a scheduler gone by now: the runs are kept without
        events, sent = (), {}
    named: dict[str, list[str]] = {}
    for _, event in events:
        if isinstance(event, dict) and event.get("chunk") in tasks.ranges:
            named.setdefault(event["chunk"], []).append(event["worker"])
    starts = {
        key: named.get(key, []) + [LOST_WORKER] * (sent.get(key, 0) - len(named.get(key, []))) for key in tasks.ranges
    }
    split = {key for key, (a, b) in tasks.ranges.items() if _halved(tasks.ranges, a, b)}
    notable = {k for key, (a, b) in tasks.ranges.items() if len(starts[key]) > 1 or key in split for k in range(a, b)}
    attempts = {
        tasks.samples.indices[k]: [w for key, (a, b) in tasks.ranges.items() if a <= k < b for w in starts[key]]
        for k in sorted(notable)
    }
    return attempts, {w for workers in named.values() for w in workers}


def _halved(ranges: dict[str, tuple[int, int]], a: int, b: int) -> bool:
    """Was the chunk of positions [a, b) sent again as halves?"""
    return b - a > 1 and (a, (a + b) // 2) in ranges.values()

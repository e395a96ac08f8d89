"""A tolerance study on a cluster in chunks of samples (issue 53, section 2): a chunk ships its
own samples' draws, the worker builds the study's problem once and evaluates chunk after chunk
as the serial study does, the chunks reach the tally in sample order, a probe per worker then
chunks sized to about a second of work (on a local cluster, a share per worker, its probe going on
into it), and a sample that kills its worker takes no other with it."""

from __future__ import annotations

import shutil
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from engine.derived import Derived
from sessions.store import load_session
from sessions.sweeps import batch_study
from sessions.sweeps.batch_study import chunk_runs, study_key
from sessions.sweeps.cluster import Connection
from sessions.sweeps.dispersion import CANCELLED, Tally
from sessions.sweeps.jobs import execute_serial
from sessions.sweeps.plan import tolerance_jobs
from sessions.sweeps.study_chunks import (
    FIRST_CHUNK,
    FIRST_SHARE,
    PROBE_RATIO,
    _InOrder,
    _one_each,
    _Sizes,
    run_chunked,
)
from tests.sessions.study_agreement import assert_measures_agree

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
LAG_LEAD = ["T1=+-10%", "T2=+-10%"]


def _samples(tmp_path: Path, count: int):
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", tmp_path / "s.json")
    return tolerance_jobs(load_session(tmp_path / "s.json"), LAG_LEAD, count, seed=4)


def test_a_shipped_chunk_holds_only_its_draws_and_makes_the_same_jobs(tmp_path):
    samples = _samples(tmp_path, 50)
    part = samples[10:20].shipped()
    assert all(len(d) == 10 for d in part.deviations.values())
    assert [job.payload() for job in part] == [job.payload() for job in samples[10:20]]
    mine, theirs = part.columns(), samples[10:20].columns()
    assert mine.keys() == theirs.keys() and all(np.array_equal(mine[name], theirs[name]) for name in mine)
    assert [job.payload() for job in part[3:5]] == [job.payload() for job in samples[13:15]]


def test_chunks_on_a_problem_built_once_reach_the_tally_as_the_serial_study(tmp_path, monkeypatch):
    """Three chunks (one of a single sample) evaluated on the problem built for the first, added
    last first: the tally's runs are the serial study's, in order."""
    samples = _samples(tmp_path, 300)
    built = []
    monkeypatch.setattr(batch_study, "_built", Derived())
    monkeypatch.setattr(batch_study, "_study", lambda jobs, build=batch_study._study: built.append(1) or build(jobs))
    pieces = [(0, 70), (70, 71), (71, 300)]
    chunks = [chunk_runs(study_key(samples), samples[a:b].shipped()) for a, b in pieces]
    assert len(built) == 1  # the problem built for the first chunk serves the others
    tally = Tally.of_study(len(samples))
    gathered = _InOrder(samples, tally)
    for (a, b), chunk in reversed(list(zip(pieces, chunks))):
        gathered.add(a, b, chunk)
    serial = execute_serial(samples).runs
    runs = tally.runs()
    assert [r["index"] for r in runs] == list(range(300)) and [r["start"] for r in runs] == [r["start"] for r in serial]
    assert_measures_agree([r["measures"] for r in runs], [r["measures"] for r in serial])


def test_samples_of_no_finished_chunk_are_cancelled_in_their_place(tmp_path):
    samples = _samples(tmp_path, 30)
    tally = Tally.of_study(len(samples))
    gathered = _InOrder(samples, tally)
    gathered.add(10, 20, chunk_runs(study_key(samples), samples[10:20].shipped()))
    gathered.finish()
    runs = tally.runs()
    assert [r["index"] for r in runs] == list(range(30))
    assert [r["index"] for r in runs if r["reason"] == CANCELLED] == [*range(10), *range(20, 30)]


def _sized(sizes: _Sizes, cost) -> list[tuple[int, int]]:
    """Every chunk of a study: the probes timed in their two parts with ``cost`` (samples -> CPU
    seconds), then each later chunk sent with one in flight and timed as it is sent."""
    ranges = sizes.first_round()
    for a, b in ranges:
        sizes.timed += [(n, cost(n)) for n in (min(sizes.first, b - a), b - a - sizes.first) if n > 0]
    while sizes.sent < sizes.count:
        chunk = sizes.next(1)
        assert chunk is not None
        ranges.append(chunk)
        sizes.timed.append((chunk[1] - chunk[0], cost(chunk[1] - chunk[0])))
    return ranges


@pytest.mark.parametrize(("count", "workers"), [(20_000, 2), (1_000, 2), (10, 2), (1, 1), (5_001, 3)])
def test_chunks_cover_the_study_once_sized_to_a_second(count, workers):
    """Chunks of 25 ms plus 0.1 ms a sample: 9750 samples are a second, more than a worker's
    two chunks hold; a chunk sized later that looked slower (0.5 s whatever its size) sizes none down."""
    sizes = _Sizes(count, workers)
    first = max(1, min(FIRST_CHUNK, count // (4 * (1 + PROBE_RATIO) * workers)))
    probes = max(2, workers)

    def cost(n: int) -> float:
        return 0.025 + 1e-4 * n if sizes.sent <= probes * (1 + PROBE_RATIO) * first else 0.5

    ranges = _sized(sizes, cost)
    assert [b - a for a, b in ranges[:probes]] == [
        min((1 + PROBE_RATIO) * first, count - a) for a, _ in ranges[:probes]
    ]
    assert [a for a, _ in ranges] == [0] + [b for _, b in ranges[:-1]] and ranges[-1][1] == count
    later = [b - a for a, b in ranges[probes:]]
    most = max(first, count // (2 * workers))
    assert all(size <= min(9750, most) for size in later)  # at least two chunks per worker
    if count == 20_000:  # 19 000 samples left after a probe per worker, at most 5000 a chunk: 4 equal chunks
        assert later == [4750] * 4


def test_a_probe_per_worker_times_two_sizes_so_the_study_takes_six_tasks():
    """Each task costs tens of ms of CPU besides its samples (the lag-lead's: 12 ms of the batch's
    fixed cost, 10-20 ms of Dask's on the worker, 15 ms in the main process).  The timed probes
    were two chunks per worker (100, 200, 100, 200) and, the first one back alone (one size), it
    was followed by another of 200: 10 tasks for 20 000 lag-lead samples on 2 workers.  Now a
    probe per worker times its two parts (100 and 400) apart, the first one back sizes the rest
    in equal chunks, as many per worker: 6 tasks (chunks of 12 ms plus 60 us a sample, as the
    lag-lead's)."""

    def cost(n: int) -> float:
        return 0.012 + 6e-5 * n

    sizes = _Sizes(20_000, 2)
    ranges = sizes.first_round()
    assert [b - a for a, b in ranges] == [500, 500] and sizes.first == 100
    sizes.timed += [(100, cost(100)), (400, cost(400))]  # the first probe back, alone
    while sizes.sent < 20_000:
        ranges.append(sizes.next(1) or (0, 0))
        sizes.timed.append((ranges[-1][1] - ranges[-1][0], cost(ranges[-1][1] - ranges[-1][0])))
    assert len(ranges) == 6 and [b - a for a, b in ranges[2:]] == [4750] * 4


def test_a_cluster_whose_workers_are_all_there_sends_a_share_per_worker_its_probe_going_on_into_it():
    """A local cluster started here has every worker from the start: no chunk is left over for a
    worker joining later, and no round trip is needed between a probe and its worker's chunk, so
    the first round is a share per worker (20 000 lag-lead samples on 2 workers: 2 tasks, not the 4
    of a probe then a chunk a worker), each worker evaluating of it what its probe says fits in a
    second (`evaluate_chunk`); what it leaves is sent first, sized from the parts timed, before the
    samples never sent.  A study too large to ship whole is shipped in shares of `FIRST_SHARE`."""
    sizes = _Sizes(20_000, 2, per_worker=1)
    assert sizes.ahead and sizes.first_round() == [(0, 10_000), (10_000, 20_000)] and sizes.left == 0
    assert not _Sizes(20_000, 2).ahead and [b - a for a, b in _Sizes(20_000, 2).first_round()] == [500, 500]
    sizes = _Sizes(1_000_000, 2, per_worker=1)
    assert sizes.first_round() == [(0, FIRST_SHARE), (FIRST_SHARE, 2 * FIRST_SHARE)]
    sizes.timed += [(100, 0.012 + 6e-5 * 100), (400, 0.012 + 6e-5 * 400), (16_000, 0.012 + 6e-5 * 16_000)]
    sizes.give_back(16_500, FIRST_SHARE)  # the first worker left the rest of its share
    assert sizes.left == 1_000_000 - 16_500 - FIRST_SHARE
    first = sizes.next(1)
    assert first is not None and first[0] == 16_500 and first[1] - first[0] == sizes.split[1] <= 16_500
    while sizes.returned:  # the share given back goes first, in chunks of the study's size
        chunk = sizes.next(1)
        assert chunk is not None and chunk[0] == first[1]
        first = chunk
    assert first[1] == FIRST_SHARE and sizes.next(1) == (2 * FIRST_SHARE, 2 * FIRST_SHARE + sizes.split[1])
    sizes = _Sizes(20_000, 2, per_worker=1)
    sizes.first_round()
    sizes.timed += [(100, 0.016), (400, 0.04), (9188, 0.95)]  # a loaded worker: 312 samples of its share left
    sizes.give_back(9688, 10_000)
    assert sizes.next(1) == (9688, 10_000) and sizes.left == 0  # in one chunk, not one a worker of 156


def test_a_probe_going_on_into_its_share_evaluates_what_fits_and_leaves_the_rest(tmp_path, monkeypatch):
    """`fitting` tells a chunk's fixed cost from a sample's by the probe's two parts; the share's
    runs are the probe's and those of the samples that fit after it, equal to the whole share's."""
    from sessions.sweeps import study_chunks
    from sessions.sweeps.study_chunks import evaluate_chunk, fitting

    assert fitting([(100, 0.016), (400, 0.034)], 1.0) == 15_666  # 10 ms + 60 us a sample, 50 ms spent
    assert fitting([(100, 0.02), (400, 0.02)], 0.1) == 600  # no slope seen: 80 us a sample (all of it), 12 ms fixed
    assert fitting([(100, 0.5), (400, 0.8)], 1.0) == 0
    samples = _samples(tmp_path, 60)
    key = study_key(samples)
    whole = chunk_runs(key, samples)
    monkeypatch.setattr(study_chunks, "fitting", lambda timed, seconds: 30)
    _, runs = evaluate_chunk(key, samples.shipped(), "t", split=2, probe=10)
    assert [n for n, _ in runs.timed] == [2, 8, 30]
    monkeypatch.setattr(study_chunks, "fitting", lambda timed, seconds: 42)  # 50 left, within a quarter of 42
    _, runs = evaluate_chunk(key, samples.shipped(), "t", split=2, probe=10)
    assert [n for n, _ in runs.timed] == [2, 8, 50]
    ours, theirs = Tally.of_study(60), Tally.of_study(60)
    for tally, chunk in ((ours, runs), (theirs, whole)):
        for item in chunk.items:
            tally.add_records(item) if not isinstance(item, dict) else tally.add(item)
    strip = {"seconds": 0, "worker": None}
    assert [{**r, **strip} for r in ours.runs()] == [{**r, **strip} for r in theirs.runs()]


def test_a_chunk_per_worker_goes_to_each_worker_the_first_to_the_probe_back():
    """The round of one chunk per worker is not left to the scheduler (it once queued both on one
    worker): the first to the worker whose probe came back, the others to the workers still on
    theirs; any other round (two a worker, halves sent again, a worker not known) goes where the
    scheduler puts it."""
    workers = ["tcp://a:1", "tcp://b:2", "tcp://c:3"]
    ranges = [(1500, 7667), (7667, 13834), (13834, 20000)]
    assert _one_each(ranges, _Sizes(20_000, 3, per_worker=1), "tcp://b:2", workers) == [
        "tcp://b:2",
        "tcp://a:1",
        "tcp://c:3",
    ]
    assert _one_each(ranges, _Sizes(20_000, 3), "tcp://b:2", workers) == [None] * 3
    assert _one_each(ranges[:2], _Sizes(20_000, 3, per_worker=1), "tcp://b:2", workers) == [None] * 2
    assert _one_each(ranges, _Sizes(20_000, 3, per_worker=1), None, workers) == [None] * 3
    assert _one_each(ranges, _Sizes(20_000, 3, per_worker=1), "tcp://b:2", []) == [None] * 3


def test_untimed_probes_size_nothing_while_a_chunk_is_in_flight_and_never_stall_the_study():
    """Probes back untimed (failed, or sent again as halves) of one size: no chunk is sized from
    one size while another chunk may time a second; with nothing in flight, the next chunk is
    of a probe's second part's size."""
    sizes = _Sizes(20_000, 2)
    sizes.first_round()
    sizes.timed.append((150, 0.02))
    assert sizes.next(1) is None
    assert sizes.next(0) == (1000, 1400)


def test_a_probe_times_its_two_parts_apart_and_its_runs_are_the_whole_chunk(tmp_path):
    samples = _samples(tmp_path, 30)
    key = study_key(samples)
    probe, whole = chunk_runs(key, samples, split=10), chunk_runs(key, samples)
    assert [n for n, _ in probe.timed] == [10, 20] and all(seconds > 0 for _, seconds in probe.timed)
    assert [n for n, _ in whole.timed] == [30]
    ours, theirs = Tally.of_study(30), Tally.of_study(30)
    for tally, runs in ((ours, probe), (theirs, whole)):
        for item in runs.items:
            tally.add_records(item) if not isinstance(item, dict) else tally.add(item)
    assert [{**r, "seconds": 0} for r in ours.runs()] == [{**r, "seconds": 0} for r in theirs.runs()]


@pytest.fixture(scope="module")
def connection():
    from distributed import Client

    from sessions.sweeps.cluster import close, local_cluster

    cluster = local_cluster(2)
    client = Client(cluster)
    yield Connection(client, cluster, 2)
    close(client, None)  # the cluster: by its own fixture's end
    cluster.close()


@pytest.mark.long
@pytest.mark.slow
def test_on_a_local_cluster_each_worker_takes_its_share_in_one_task(tmp_path, connection):
    """Its workers all there from the start (`Connection.fixed`): 4000 samples in 2 tasks, a
    share on each worker, its probe going on into it (their starts, as the scheduler logged them),
    equal to serial."""
    from sessions.sweeps.jobs import EVENT_TOPIC

    samples = _samples(tmp_path, 4000)
    earlier = {e.get("chunk") for _, e in connection.client.get_events(EVENT_TOPIC) if isinstance(e, dict)}
    outcome = run_chunked(connection._replace(fixed=True), samples)
    starts = [e for _, e in connection.client.get_events(EVENT_TOPIC) if e.get("chunk") not in earlier]
    assert len(starts) == 2 and sorted(Counter(e["worker"] for e in starts).values()) == [1, 1], starts
    assert outcome.workers == 2 and "2 chunks of 2000-2000" in outcome.note
    serial = execute_serial(samples).runs
    assert_measures_agree([r["measures"] for r in outcome.runs], [r["measures"] for r in serial])


@pytest.mark.slow
def test_the_rest_a_share_leaves_is_sent_again_and_counted_once(tmp_path, monkeypatch):
    """Each worker's share evaluated only as far as its probe (nothing fits after it here): the rest
    of each share goes in later chunks, every sample evaluated once (no retry recorded), the note's
    chunks the ranges each task evaluated, the rows the serial study's."""
    from distributed import Client, LocalCluster

    from sessions.sweeps import study_chunks

    monkeypatch.setattr(study_chunks, "fitting", lambda timed, seconds: 0)
    samples = _samples(tmp_path, 400)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as local:
        with Client(local) as client:
            outcome = run_chunked(Connection(client, local, 2, fixed=True), samples)
    runs = outcome.runs
    assert [r["index"] for r in runs] == list(range(400)) and not outcome.attempts
    assert all(r["status"] != "failed" and r.get("attempts", 1) == 1 for r in runs)
    assert sum(n for n, _ in outcome.chunks) == 400 and len(outcome.chunks) > 2
    assert f"in {len(outcome.chunks)} chunks of " in outcome.note, outcome.note
    serial = execute_serial(samples).runs
    assert_measures_agree([r["measures"] for r in runs], [r["measures"] for r in serial])


@pytest.mark.long
@pytest.mark.slow
def test_a_cancelled_study_keeps_its_finished_chunks_whole(tmp_path, connection):
    samples = _samples(tmp_path, 400)
    outcome = run_chunked(connection, samples, cancelled=lambda: True)  # cancelled at the first finished chunk
    runs = outcome.runs
    assert outcome.cancelled and [r["index"] for r in runs] == list(range(400))
    finished = {r["index"] for r in runs if r["reason"] != CANCELLED}
    whole = [set(range(a, b)) for a, b in _Sizes(400, 2).first_round() if set(range(a, b)) <= finished]
    assert finished and finished == set().union(*whole)  # whole chunks of the first round
    assert all(r["worker"].startswith("tcp://") for r in runs if r["reason"] != CANCELLED)


@pytest.mark.long
@pytest.mark.slow
def test_a_sample_that_kills_its_worker_takes_no_other_sample_with_it(tmp_path):
    """Its chunk is sent again as halves down to the sample alone, which is recorded as failed
    (one death fails a task here: a sample whose task was on the worker when the poison killed it
    may fail beside it, never one outside the poison's first chunk; 64 samples go in probes of 5
    first, one of 1 and 4 samples timed apart)."""
    import dask
    from distributed import Client

    from sessions.sweeps.cluster import close, local_cluster
    from tests.sessions.sweep_poison import POISON, poisoned_chunk

    samples = _samples(tmp_path, 64)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0, "distributed.scheduler.worker-saturation": 1.0}):
        cluster = local_cluster(2)
    client = Client(cluster)
    try:
        outcome = run_chunked(Connection(client, cluster, 2), samples, task=poisoned_chunk)
    finally:
        close(client, cluster)
    runs = outcome.runs
    assert [r["index"] for r in runs] == list(range(64))
    failed = {r["index"] for r in runs if r["status"] == "failed"}
    chunk = next(range(a, b) for a, b in _Sizes(64, 2).first_round() if a <= POISON < b)
    assert POISON in failed and failed <= set(chunk) and len(failed) < len(chunk), failed
    assert all("workers died while running it" in runs[k]["reason"] for k in failed)
    serial = execute_serial(samples).runs
    kept = [k for k in range(64) if k not in failed]
    assert_measures_agree([runs[k]["measures"] for k in kept], [serial[k]["measures"] for k in kept])


@pytest.mark.slow
def test_a_chunk_that_never_finishes_is_given_up_and_the_study_finishes(tmp_path, monkeypatch):
    """A chunk whose task never returns (a hung worker: here it waits until the study is over)
    while the others finish: once no result has come for the stall bound (1 s here, and once the
    longest wait between results so far), its samples are recorded not computed and named in the
    note; every other sample is the serial study's."""
    from distributed import Client, LocalCluster

    from sessions.sweeps import cluster
    from sessions.sweeps.cluster import NOT_COMPUTED
    from tests.sessions.sweep_poison import POISON, RELEASE, hung_chunk

    monkeypatch.setattr(cluster, "STALL_WAIT", 1.0)
    monkeypatch.setattr(cluster, "STALL_FACTOR", 1.0)
    samples = _samples(tmp_path, 64)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as local:
        with Client(local) as client:
            try:
                outcome = run_chunked(Connection(client, local, 1), samples, task=hung_chunk)
            finally:
                RELEASE.set()
    runs = outcome.runs
    assert [r["index"] for r in runs] == list(range(64))
    lost = {r["index"] for r in runs if r["status"] == "failed"}
    assert POISON in lost and all(runs[k]["reason"].startswith(f"{NOT_COMPUTED}: no task finished for") for k in lost)
    hung = next(range(a, b) for a, b in _Sizes(64, 1).first_round() if a <= POISON < b)
    assert lost == set(hung), lost  # the other probe's timings sized the rest: none waited on the hung one
    assert outcome.given_up in outcome.note and f"({len(lost)} samples recorded as failed)" in outcome.note
    # every chunk that finished, timed on its worker (the bench's CPU accounting reads them)
    assert sum(n for n, _ in outcome.chunks) == 64 - len(lost) and all(seconds > 0 for _, seconds in outcome.chunks)
    serial = execute_serial(samples).runs
    kept = [k for k in range(64) if k not in lost]
    assert_measures_agree([runs[k]["measures"] for k in kept], [serial[k]["measures"] for k in kept])

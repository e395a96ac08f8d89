"""A tolerance study evaluated as a batch: its samples are one session at other
parameter values, so the problem is built and bound once, every condition's loop is
put in pole-zero form for a chunk of samples at once (`engine.loop.batch_forms`) and
its margins found by the certified grid-free search on each form
(`engine.margins.batch`), without a session, a problem, a network response or a
realization per sample.  Each sample's run is the one `sessions.sweeps.jobs.run_job`
gives (its rows are slp's own: `Slp.point_at` and `Slp.rows`, vectorized over the samples
by `engine.slp.points`); consecutive batched samples are handed on as arrays
(`sessions.sweeps.records.Records`), a run made only when it is kept.

It applies to slp studies with no linear constraints between parameters (a tolerance
study's document has none: `sessions.sweeps.plan.tolerance_jobs` leaves them out), whose
drawn parameters are free.  Their samples are batched when the rows are margins, crossover
frequencies, modal peaks (the attenuation margins), time rows (step measures and the peak
response, `engine.slp.batch_rows`: each sample's closed loop realized as the per-loop path
realizes it, every response simulated in one recursion, a loop in z's stepped in z), Ms, Mt, disk and
delay margins (`engine.margins.batch.closed_rows`: the peaks of every sample found at once) and the closed-loop stability abscissa, of conditions whose loops are
cascades of expression blocks, in s or in z (through the w-plane form the problem holds,
`engine.margins.batch`), or diagrams in s or in z (their w-plane form) realized for every sample
at once (`engine.loop.batch_realization`: parallel paths, inner loops, state-space blocks of one
port or several), whose minimal forms come
from the stacked realizations (`engine.loop.batch_realized_forms`) and whose margins are
polished on them; a row that names another break of its diagram reads the loop broken
there (each (condition, break) its own forms).  A sample the batch cannot certify (its form is odd, its
search fails its certificate, a level is constant, a crossover is absent), and every
sample of a study that is not batched (a delay, a table, a diagram with no batched
realization, a mean square), is
evaluated per loop, by slp's own measures (`engine.slp.measures.evaluate`) on the problem
built once: what `run_job` computes but for building the sample's session (a sample whose
evaluation raises gets `run_job` itself).  The study's note says which samples went per loop, and why a study
is not batched.  Another algorithm's study, or one with linear constraints, runs per
loop from each sample's session.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from engine.derived import Derived, Form
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.batch_forms import BatchForms, batch_pole_zero
from engine.loop.batch_realization import batch_loop_realization, closed_of
from engine.loop.batch_realized_forms import RealizedForms, realized_forms
from engine.loop.realization import StateSpace
from engine.margins.batch import BatchLoops, ClosedRows, batch_loops, closed_rows
from engine.margins.peak_measures import CLOSED_LOOP_MEASURES
from engine.model.network import Network
from engine.slp import REGISTRATION as SLP
from engine.slp.algorithm import Slp
from engine.slp.batch_rows import BATCH_TIME_KINDS, Assisted, Stacks, assisted, batch_time_rows, condition_stacks
from engine.slp.measures import PEAK_KINDS, Spec, evaluate, frequency_values, spec_break
from engine.slp.points import points
from sessions.build import build_problem
from sessions.errors import SessionError
from sessions.lifecycle import bind
from sessions.store import validated_model
from sessions.sweeps.dispersion import Tally
from sessions.sweeps.jobs import run_job
from sessions.sweeps.plan import ToleranceSamples
from sessions.sweeps.records import Head, Heads, Records, RowHead, number, row_heads, sample_run

BATCH_KINDS = frozenset(
    (
        "crossover_frequency",
        "gain_margin",
        "gain_margin_db",
        "phase_margin",
        "phase_margin_deg",
        "stability_abscissa",
        *PEAK_KINDS,
        *BATCH_TIME_KINDS,
        *CLOSED_LOOP_MEASURES,
    )
)
# samples whose forms are held at once: the memory stays bounded however large the study (100 000
# lag-lead samples: 82 MB peak at 2000, 98 MB at 5000, where a chunk's fixed cost is 3 us a sample less)
CHUNK = 5000


@dataclass(frozen=True)
class BatchOutcome:
    """The samples' runs in job order (all of them unless ``interrupted``: Ctrl-C stopped the
    study after the first ``done``; none when they went to a `Tally`), and which samples went
    the per-loop path or the per-loop search on their batched forms."""

    runs: list[dict]
    done: int
    alone: tuple[int, ...] = ()  # the samples that went the per-loop path
    by_search: tuple[int, ...] = ()  # the samples the per-loop search found on their batched forms
    interrupted: bool = False
    unbatched: str = ""  # why the study is not batched (its samples all go per loop); "" when it is

    @property
    def per_loop(self) -> int:
        """How many samples went the per-loop path."""
        return len(self.alone)

    @property
    def searched(self) -> int:
        """How many samples the per-loop search found on their batched forms."""
        return len(self.by_search)

    @property
    def note(self) -> str:
        """What the study's summary says of the batch, naming the samples the batch did not certify."""
        if self.unbatched:
            return (
                f"{self.done} samples evaluated per loop on the study's problem, built once "
                f"(not batched: {self.unbatched})"
            )
        return (
            f"{self.done - self.per_loop - self.searched} of {self.done} samples evaluated as a batch, "
            f"{self.searched} by the per-loop search on their batched forms{_named(self.by_search)} and "
            f"{self.per_loop} on the per-loop path (their batch certificate failed){_named(self.alone)}"
        )


NAMED = 10  # samples named in the note (the first ones), of those the batch did not certify


def _named(samples: tuple[int, ...]) -> str:
    if not samples:
        return ""
    listed = ", ".join(str(k) for k in samples[:NAMED])
    return f" (sample{'s' if len(samples) > 1 else ''} {listed}{', ...' if len(samples) > NAMED else ''})"


@dataclass
class _Study:
    """The problem and slp stepper built once, the start's free vector and named values, and
    which free slots (name, condition) the samples draw."""

    problem: Problem
    stepper: Slp
    start: np.ndarray
    named: dict
    slots: list[tuple[int, str, int | None]]
    unbatched: str  # why its samples are not batched ("" when they are)
    assisted: bool  # not batched, but its realizations, time and stability rows are (`engine.slp.batch_rows.assisted`)
    signed: tuple[np.ndarray, np.ndarray]  # each free slot's range by its parameter's sign (-inf, 0 or +inf)
    row_heads: list[RowHead]  # what every run says of each row but its value


def batch_runs(
    jobs: Sequence,
    progress: Callable[[int, int], None] | None = None,
    tally: Tally | None = None,
    unbatched: bool = True,
) -> BatchOutcome | None:
    """The runs of a tolerance study's evaluate jobs as a batch, chunk by chunk (`CHUNK`),
    each chunk's runs added to ``tally`` when given (then none is returned: only the chunk's
    runs are held at once); None when the study is not one this applies to (module
    docstring), or, without ``unbatched``, when its samples would all go per loop."""
    study = _study(jobs)
    if study is None or (study.unbatched and not unbatched):
        return None
    runs: list[dict] = []
    alone: list[int] = []
    searched: list[int] = []
    done = 0
    try:
        for first in range(0, len(jobs), CHUNK):
            part = jobs[first : first + CHUNK]
            for item in _chunk(study, part, alone, searched):
                if isinstance(item, Records):
                    if tally is None:
                        runs += item.runs()
                    else:
                        tally.add_records(item)
                elif tally is None:
                    runs.append(item)
                else:
                    tally.add(item)
            done += len(part)
            if progress:
                progress(done, len(jobs))
    except KeyboardInterrupt:
        return BatchOutcome(runs, done, tuple(alone), tuple(searched), True, study.unbatched)
    return BatchOutcome(runs, done, tuple(alone), tuple(searched), False, study.unbatched)


def applies(jobs: Sequence) -> bool:
    """Are the jobs a tolerance study's samples that `chunk_runs` evaluates on a problem built once
    (batched or per loop: the module docstring)?"""
    return isinstance(jobs, ToleranceSamples) and _study(jobs) is not None


STUDIES_KEPT = 4  # the studies a worker keeps built, the latest used (a long-lived worker serves many)
_built = Derived(STUDIES_KEPT)  # a study's problem built once, by its key (`study_key`)
_BUILT_STUDY: Form[_Study] = Form("a tolerance study's problem and slp stepper, built once")


@dataclass(frozen=True)
class ChunkRuns:
    """A chunk of a study's samples evaluated (`chunk_runs`): its runs in order (stretches of
    batched samples as `Records`), the samples that went the per-loop path or the per-loop
    search on their batched forms, why the study is not batched ("" when it is), and the CPU
    seconds its parts' samples took, each part's (samples, seconds) (the evaluating thread's,
    building the study's problem apart: the work, whatever else a loaded machine runs meanwhile)."""

    items: list[dict | Records]
    alone: tuple[int, ...]
    by_search: tuple[int, ...]
    unbatched: str
    timed: tuple[tuple[int, float], ...]

    @property
    def cpu_seconds(self) -> float:
        return sum(seconds for _, seconds in self.timed)


def study_key(samples: ToleranceSamples) -> str:
    """What identifies a study's problem: its document and the parameters its samples draw."""
    text = json.dumps([samples.base, sorted(samples.deviations)], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def chunk_runs(key: str, samples: ToleranceSamples, split: int = 0) -> ChunkRuns:
    """A chunk of a study's samples evaluated as `batch_runs` evaluates them, on the study's
    problem built once in this process (kept under ``key``, `study_key`, for its next chunks:
    the last `STUDIES_KEPT` studies), the first ``split`` samples (when 0 < split < len) a part
    timed apart from the rest (a probe: two sizes timed in one task); a `SessionError` when the
    samples are not such a study."""
    study = _built.get(_BUILT_STUDY, lambda: _one_study(samples), key)
    items: list[dict | Records] = []
    alone: list[int] = []
    searched: list[int] = []
    timed: list[tuple[int, float]] = []
    for part in [samples[:split], samples[split:]] if 0 < split < len(samples) else [samples]:
        began = time.thread_time()
        for first in range(0, len(part), CHUNK):
            items += _chunk(study, part[first : first + CHUNK], alone, searched)
        timed.append((len(part), time.thread_time() - began))
    return ChunkRuns(items, tuple(alone), tuple(searched), study.unbatched, tuple(timed))


def _one_study(samples: ToleranceSamples) -> _Study:
    study = _study(samples)
    if study is None:
        raise SessionError("the samples are not a study evaluated on its problem built once")
    return study


def _study(jobs: Sequence) -> _Study | None:
    """The shared problem and stepper, when every job evaluates one structure with slp, without
    linear constraints, drawing free parameters (module docstring)."""
    if not jobs or not _one_structure(jobs):
        return None
    try:
        model = validated_model(jobs[0].model)
        problem = build_problem(model.problem, Path.cwd())
        _, stepper = bind(model.algorithm, problem)
    except (SessionError, EngineError, ValueError):
        return None
    if not isinstance(stepper, Slp):
        return None
    if problem.linear_constraints[0].size or problem.equality_system()[0].size:
        return None
    lower, upper = problem.bounds()
    start = np.clip(problem.vector(), lower, upper)
    slots = [
        (k, problem.parameters[i].name, c)
        for k, (i, c) in enumerate(problem.free_slots())
        if problem.parameters[i].name in jobs[0].start
    ]
    if not set(jobs[0].start) <= {name for _, name, _ in slots}:
        return None  # a drawn parameter that is not free: the free vector does not carry it
    others = sorted({s.kind for s in stepper.specs} - BATCH_KINDS)
    unbatched = f"rows of kind {', '.join(others)}" if others else ""
    if not unbatched and not all(c.network.rational for c in problem.conditions):
        unbatched = "a loop with a delay or a table"  # (a state-space block is rational: realized in batch)
    timed = {s.condition for s in stepper.specs if s.kind in BATCH_TIME_KINDS}
    for c, break_at in _every_break(problem, stepper.specs):
        if not unbatched and _cascade(problem, c, break_at) is None:
            name = problem.conditions[c].name
            unbatched = f"condition {name!r}'s loop at {break_at!r} has no batch form ({NO_FORM})"
    helped = bool(unbatched) and _assisted(problem)
    if helped:
        rows = "its realizations, time rows and stability rows" if timed else "its realizations and stability rows"
        unbatched += f"; batched: {rows}; per loop: its frequency rows"
    signs = [problem.parameters[i].sign for i, _ in problem.free_slots()]
    signed = (
        np.array([0.0 if sign == "positive" else -math.inf for sign in signs]),
        np.array([0.0 if sign == "negative" else math.inf for sign in signs]),
    )
    heads = row_heads(stepper.specs, [condition.name for condition in problem.conditions])
    return _Study(problem, stepper, start, problem.named(start), slots, unbatched, helped, signed, heads)


def _assisted(problem: Problem) -> bool:
    """Can the study's realizations be made for all its samples at once (its frequency rows then
    go per loop on them)?  Every condition continuous, its loop realized at once at the start."""
    if any(condition.network.sample_time is not None for condition in problem.conditions):
        return False
    start = problem.vector()[None, :]
    return all(condition_stacks(problem, c, start) is not None for c in range(len(problem.conditions)))


def _cascade(problem: Problem, c: int, break_at: str) -> BatchForms | None:
    """Condition ``c``'s loop broken at ``break_at`` at the design's values in batch form (None: it has none)."""
    condition = problem.conditions[c]
    columns = {name: np.array([value]) for name, value in problem.condition_values(c).items()}
    return batch_form(condition.network, break_at, columns)[0]


NO_FORM = "neither one cascade of expression blocks nor a diagram realized for every sample at once"


def batch_form(
    network: Network, break_at: str, columns: dict[str, np.ndarray]
) -> tuple[BatchForms | None, RealizedForms | None]:
    """Every sample's loop in pole-zero form: a cascade's from its blocks' factors
    (`engine.loop.batch_forms`), any other loop's minimal form from its stacked realizations
    (`engine.loop.batch_realized_forms`, returned too: its margins are polished on them; a loop
    in z's in its w-plane form); (None, None) when it has neither."""
    forms = batch_pole_zero(network, break_at, columns)
    if forms is not None:
        return forms, None
    broken = batch_loop_realization(network, break_at, columns, shared=True)
    exact = None if broken is None else realized_forms(broken, network.signal(break_at))
    return (None, None) if exact is None else (exact.forms, exact)


def _one_structure(jobs: Sequence) -> bool:
    """Are the jobs evaluations of one session document but for their parameters' values and
    bounds, each drawing the same parameters (what a tolerance study's samples share)?"""
    if isinstance(jobs, ToleranceSamples):  # one study's samples: one document by construction
        return jobs.base.get("algorithm", {}).get("name") == SLP.name
    if any(getattr(job, "mode", None) != "evaluate" for job in jobs):
        return False
    base = jobs[0].model
    if base.get("algorithm", {}).get("name") != SLP.name:  # the batch records a sample as slp does
        return False
    study = getattr(jobs[0], "study", None)
    if study is not None and all(getattr(job, "study", None) is study for job in jobs):
        return True  # samples of one study (`sessions.sweeps.plan.tolerance_jobs`): one document by construction
    problem, drawn = base["problem"], set(jobs[0].start)
    for job in jobs:
        model = job.model
        if set(job.start) != drawn or not _equal_but(model, base, ("problem",)):
            return False
        if not _equal_but(model["problem"], problem, ("parameters",)):
            return False
        entries, others = model["problem"]["parameters"], problem["parameters"]
        if len(entries) != len(others) or not all(a is b or _equal_but(a, b, _VALUES) for a, b in zip(entries, others)):
            return False
    return True


_VALUES = ("value", "min", "max")


def _equal_but(a: dict, b: dict, skip: tuple[str, ...]) -> bool:
    """Do two dicts hold the same keys and values but for ``skip`` (shared values compared by identity first)?"""
    return a.keys() == b.keys() and all(a[k] is b[k] or a[k] == b[k] for k in a if k not in skip)


def _chunk(study: _Study, jobs: Sequence, alone: list[int], searched: list[int]) -> list[dict | Records]:
    """One chunk's runs in order: stretches of batched samples as arrays (`Records`), the
    per-loop path's runs for the samples the batch leaves; the samples that went the
    per-loop path added to ``alone``, those the per-loop search on their batched forms found
    to ``searched``.  A chunk of `ToleranceSamples` makes a job only for a sample that goes
    the per-loop path."""
    began = time.perf_counter()
    heads: Sequence[Head]
    if isinstance(jobs, ToleranceSamples):
        columns = jobs.columns()
        heads = Heads(np.asarray(jobs.indices, dtype=np.int64), columns)
    else:
        heads = [(job.index, job.label, job.start) for job in jobs]
        columns = _columns(heads)
    xs = np.tile(study.start, (len(heads), 1))
    for k, name, c in study.slots:
        xs[:, k] = _seen_by(columns[name], c)
    # a value against its parameter's sign: its own session evaluates it at the sign's bound (slp clips its start)
    against_sign = ((xs < study.signed[0]) | (xs > study.signed[1])).any(axis=1)
    loops = (
        {}
        if study.unbatched
        else {
            at: _condition_loops(study, *at, columns, len(heads))
            for at in _every_break(study.problem, study.stepper.specs)
        }
    )
    timed, timed_ok = _time_rows(study, xs, loops)
    helped = assisted(study.problem, study.stepper.specs, xs) if study.assisted else None
    if study.unbatched or any(found is None for found in loops.values()):
        values = frequencies = np.zeros((len(heads), 0))
        batched = by_search = np.zeros(len(heads), dtype=bool)
    else:
        values, frequencies, batched, by_search = _row_values(
            study, {at: found for at, found in loops.items() if found}, timed
        )
        batched &= ~against_sign & timed_ok
        by_search &= batched
    share = (time.perf_counter() - began) / max(len(heads), 1)
    searched += [heads[k][0] for k in np.flatnonzero(by_search).tolist()]
    items: list[dict | Records] = []
    edges = np.flatnonzero(np.diff(batched.astype(np.int8))) + 1
    for a, b in zip([0, *edges.tolist()], [*edges.tolist(), len(heads)]):
        if a < b and batched[a]:
            items += _records(study, heads[a:b], values[a:b], frequencies[a:b], share)
            continue
        for k in range(a, b):
            run = (None if against_sign[k] else _per_loop(study, heads[k], xs[k], helped, k)) or run_job(
                jobs[k].payload()
            )
            alone.append(heads[k][0])
            run["attempts"] = 1
            items.append(run)
    return items


def _records(
    study: _Study, heads: Sequence[Head], values: np.ndarray, frequencies: np.ndarray, share: float
) -> list[dict | Records]:
    """Consecutive batched samples' runs as arrays (each sample's run made whole under an
    objective the arrays do not judge, `engine.slp.points`)."""
    verdicts = points(study.stepper.specs, study.stepper.settings.objective, values, frequencies)
    if verdicts is None:
        return [
            {**_sample_run(study, head, study.start, values[j], frequencies[j], share), "attempts": 1}
            for j, head in enumerate(heads)
        ]
    return [Records(heads, study.row_heads, values, frequencies, verdicts, study.named, share)]


def _per_loop(study: _Study, head: Head, x: np.ndarray, helped: Assisted | None = None, k: int = 0) -> dict | None:
    """One sample's run by slp's own measures on the shared problem (what `run_job` computes
    from the sample's session; ``helped``: with the chunk's batched realizations and rows, ``k``
    its position there); None when they raise (`run_job` says how)."""
    began = time.perf_counter()
    try:
        if helped is not None:
            values, frequencies = helped.evaluate(k, x)
        else:
            values, frequencies = evaluate(study.problem, x, study.stepper.specs)
    except Exception:  # noqa: BLE001 - the sample's own session then says what failed, as run_job does
        return None
    return _sample_run(study, head, x, values, frequencies, time.perf_counter() - began)


def _columns(heads: list[Head]) -> dict[str, np.ndarray]:
    """The drawn values of jobs (their heads' starts) as `ToleranceSamples.columns` gives them."""
    return (
        {name: np.array([start[name] for _, _, start in heads], dtype=float) for name in heads[0][2]} if heads else {}
    )


def _seen_by(column: np.ndarray, condition: int | None) -> np.ndarray:
    """A drawn column as one condition sees it (a per-condition parameter's entries)."""
    return column[:, condition] if column.ndim == 2 and condition is not None else column


class _Loops(NamedTuple):
    """A condition's loop of every sample: its margins as arrays and, when it has closed-loop rows,
    every sample's rows (`engine.margins.batch.closed_rows`)."""

    margins: BatchLoops
    closed: ClosedRows | None
    realized: StateSpace | None = None  # its broken loops' stacked realizations, when its forms came from them


def _every_break(problem: Problem, specs: Sequence[Spec]) -> list[tuple[int, str]]:
    """Every (condition, break) a row reads its loop at, each condition's own break first
    (`engine.slp.measures.spec_break`: a row may name another break of its diagram)."""
    conditions = problem.conditions
    out = [(c, condition.break_at) for c, condition in enumerate(conditions)]
    for spec in specs:
        at = (spec.condition, spec_break(spec, conditions[spec.condition]))
        if at not in out:
            out.append(at)
    return out


def _condition_loops(study: _Study, c: int, break_at: str, drawn: dict[str, np.ndarray], count: int) -> _Loops | None:
    """Condition ``c``'s loop broken at ``break_at`` of every sample (``drawn``: the drawn
    parameters' columns, ``count`` samples), margins found; None when it has no batch form (the
    study is then not batched: it says why)."""
    problem = study.problem
    condition = problem.conditions[c]
    columns = {name: np.full(count, value) for name, value in problem.condition_values(c).items()}
    columns |= {name: _seen_by(column, c) for name, column in drawn.items() if name in columns}
    forms, exact = batch_form(condition.network, break_at, columns)
    if forms is None:
        study.unbatched = f"condition {condition.name!r}'s loop at {break_at!r} has no batch form ({NO_FORM})"
        return None
    mine = [(i, s) for i, s in enumerate(study.stepper.specs) if (s.condition, _at(study, s)) == (c, break_at)]
    peaks = any(spec.kind in PEAK_KINDS for _, spec in mine)
    loops = batch_loops(forms, condition.network.sample_time, attenuation=peaks, exact=exact)
    closed = [(i, s.kind, s.low, s.high) for i, s in mine if s.kind in CLOSED_LOOP_MEASURES]
    realized = None if exact is None else exact.realization
    if not closed:
        return _Loops(loops, None, realized)
    return _Loops(loops, closed_rows(forms, loops, closed, condition.network.sample_time), realized)


def _at(study: _Study, spec: Spec) -> str:
    """The break a row reads its loop at."""
    return spec_break(spec, study.problem.conditions[spec.condition])


def _time_rows(
    study: _Study, xs: np.ndarray, loops: dict[tuple[int, str], _Loops | None]
) -> tuple[np.ndarray, np.ndarray]:
    """Every sample's time rows and the stability rows of their conditions (`engine.slp.batch_rows`;
    NaN columns for the other rows, all NaN when the study has no time rows), and which samples
    have them."""
    specs = study.stepper.specs
    if study.unbatched or not any(s.kind in BATCH_TIME_KINDS for s in specs):
        return np.full((xs.shape[0], len(specs)), np.nan), np.ones(xs.shape[0], dtype=bool)
    stacks: dict[int, Stacks | None] = {}
    for c, condition in enumerate(study.problem.conditions):  # the realizations its forms came from, closed here
        found = loops.get((c, condition.break_at))
        if found is not None and found.realized is not None:
            closed = closed_of(condition.network, condition.break_at, found.realized)
            stacks[c] = None if closed is None else (found.realized, closed)
    return batch_time_rows(study.problem, specs, xs, stacks)


def _row_values(
    study: _Study, loops: dict[tuple[int, str], _Loops], timed: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every sample's row values and frequencies (samples, rows) from its conditions' loops and
    its time rows (``timed``: NaN but for the time rows and their conditions' stability rows),
    the samples whose rows the batch gives (the others need the per-loop path), and those of
    them some loop of which the per-loop search on its form found."""
    specs = study.stepper.specs
    values, frequencies = np.full((timed.shape[0], len(specs)), np.nan), np.full((timed.shape[0], len(specs)), np.nan)
    ok = np.ones(timed.shape[0], dtype=bool)
    for i, spec in enumerate(specs):
        loop = loops[spec.condition, _at(study, spec)]
        ok &= loop.margins.found
        if spec.kind in BATCH_TIME_KINDS:
            values[:, i] = timed[:, i]
        elif spec.kind in CLOSED_LOOP_MEASURES and loop.closed is not None:
            ok &= loop.closed.found
            column = loop.closed.columns[i]
            values[:, i], frequencies[:, i] = loop.closed.values[:, column], loop.closed.frequencies[:, column]
        elif spec.kind == "stability_abscissa":  # the closed loop's eigenvalues when it was realized
            values[:, i] = np.where(np.isnan(timed[:, i]), loop.margins.abscissa, timed[:, i])
        else:
            values[:, i], frequencies[:, i], per_loop = frequency_values(spec, loop.margins)
            ok &= ~per_loop
    certified = [
        loop.margins.batched & (True if loop.closed is None else loop.closed.batched) for loop in loops.values()
    ]
    return values, frequencies, ok, ~np.logical_and.reduce(certified)


def _sample_run(
    study: _Study,
    head: Head,
    x: np.ndarray,
    values: np.ndarray,
    frequencies: np.ndarray,
    seconds: float,
) -> dict:
    """The run of a sample whose rows have these values and frequencies, as `run_job` makes it."""
    stepper = study.stepper
    point = stepper.point_at(x, values, frequencies)
    rows = [_row_json(fields) for fields in stepper.row_fields(point)]
    return sample_run(head, study.named, point.merit, rows, seconds)


def _row_json(fields: tuple) -> dict:
    """A tableau row (its `MeasureRow` fields, in their order) as `StepRecord.to_json` writes it
    (non-finite numbers as 'inf', '-inf', 'nan')."""
    name, kind, condition, value, desired, satisfied, frequency, at_least, method = fields
    return {
        "name": name,
        "kind": kind,
        "condition": condition,
        "value": number(value),
        "desired": number(desired),
        "satisfied": satisfied,
        "frequency": number(frequency),
        "at_least": at_least,
        "method": method,
    }

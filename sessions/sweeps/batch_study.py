"""A tolerance study evaluated as a batch: its samples are one session at other
parameter values, so the problem is built and bound once, every condition's loop is
put in pole-zero form for a chunk of samples at once (`engine.loop.batch_forms`) and
its margins found by the certified grid-free search on each form
(`engine.margins.batch`), without a session, a problem, a network response or a
realization per sample.  Each sample's run is the one `sessions.sweeps.jobs.run_job`
gives (its rows are slp's own, `Slp.point_at` and `Slp.rows`).

It applies to slp studies whose rows are margins, crossover frequencies and the
closed-loop stability abscissa, of conditions whose loops are cascades of
expression blocks, with no linear constraints between parameters.  Any other study
(a delay, a table, a state-space block, time or peak measures, another algorithm)
runs per loop, as does each sample the batch cannot certify (its form is odd, its
search fails its certificate, a level is constant, a crossover is absent): the
study's note says how many.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.batch_forms import batch_pole_zero
from engine.margins.batch import SampleLoop, batch_margins
from engine.slp import REGISTRATION as SLP
from engine.slp.algorithm import Slp
from engine.slp.measures import frequency_value
from sessions.build import build_problem
from sessions.errors import SessionError
from sessions.lifecycle import bind
from sessions.store import validated_model
from sessions.sweeps.jobs import run_job

BATCH_KINDS = frozenset(
    ("crossover_frequency", "gain_margin", "gain_margin_db", "phase_margin", "phase_margin_deg", "stability_abscissa")
)
CHUNK = 2000  # samples whose forms are held at once: the memory stays bounded however large the study


@dataclass(frozen=True)
class BatchOutcome:
    """The samples' runs in job order (all of them unless ``interrupted``: Ctrl-C stopped the
    study after these), and how many of them went the per-loop path."""

    runs: list[dict]
    per_loop: int
    searched: int = 0  # samples whose forms were batched but whose margins the per-loop search found
    interrupted: bool = False

    @property
    def note(self) -> str:
        """What the study's summary says of the batch."""
        return (
            f"{len(self.runs) - self.per_loop - self.searched} of {len(self.runs)} samples evaluated as a batch, "
            f"{self.searched} by the per-loop search on their batched forms and {self.per_loop} on the per-loop "
            "path (their batch certificate failed)"
        )


@dataclass
class _Study:
    """The problem and slp stepper built once, the start's free vector and named values, and
    which free slots (name, condition) the samples draw."""

    problem: Problem
    stepper: Slp
    start: np.ndarray
    named: dict
    slots: list[tuple[int, str, int | None]]


def batch_runs(jobs: Sequence, progress: Callable[[int, int], None] | None = None) -> BatchOutcome | None:
    """The runs of a tolerance study's evaluate jobs as a batch, chunk by chunk (`CHUNK`);
    None when the study is not one the batch applies to (module docstring)."""
    study = _study(jobs)
    if study is None:
        return None
    runs: list[dict] = []
    per_loop = searched = 0
    try:
        for first in range(0, len(jobs), CHUNK):
            chunk, (missed, alone) = _chunk(study, jobs[first : first + CHUNK])
            runs += chunk
            per_loop, searched = per_loop + missed, searched + alone
            if progress:
                progress(len(runs), len(jobs))
    except KeyboardInterrupt:
        return BatchOutcome(runs, per_loop, searched, interrupted=True)
    return BatchOutcome(runs, per_loop, searched)


def _study(jobs: Sequence) -> _Study | None:
    """The shared problem and stepper, when every job evaluates one structure with slp's batchable rows."""
    if not jobs or any(getattr(job, "mode", None) != "evaluate" for job in jobs) or not _one_structure(jobs):
        return None
    try:
        model = validated_model(jobs[0].model)
        problem = build_problem(model.problem, Path.cwd())
        _, stepper = bind(model.algorithm, problem)
    except (SessionError, EngineError, ValueError):
        return None
    if not isinstance(stepper, Slp) or not all(s.kind in BATCH_KINDS for s in stepper.specs):
        return None
    if problem.linear_constraints[0].size or problem.equality_system()[0].size:
        return None
    if not all(c.network.rational for c in problem.conditions):
        return None
    lower, upper = problem.bounds()
    start = np.clip(problem.vector(), lower, upper)
    slots = [
        (k, problem.parameters[i].name, c)
        for k, (i, c) in enumerate(problem.free_slots())
        if problem.parameters[i].name in jobs[0].start
    ]
    return _Study(problem, stepper, start, problem.named(start), slots)


def _one_structure(jobs: Sequence) -> bool:
    """Are the jobs one session document but for their parameters' values and bounds, each
    drawing the same parameters (what a tolerance study's samples share)?"""
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


def _chunk(study: _Study, jobs: Sequence) -> tuple[list[dict], tuple[int, int]]:
    """One chunk's runs (the batch's, or the per-loop path's for the samples it leaves), and
    how many went the per-loop path and how many the per-loop search on their batched forms."""
    began = time.perf_counter()
    xs = np.tile(study.start, (len(jobs), 1))
    for k, name, c in study.slots:
        xs[:, k] = [_drawn(job.start[name], c) for job in jobs]
    loops = [_condition_loops(study.problem, c, jobs) for c in range(len(study.problem.conditions))]
    share = (time.perf_counter() - began) / max(len(jobs), 1)
    runs, missed, alone = [], 0, 0
    for k, job in enumerate(jobs):
        mine = None if any(found is None for found in loops) else [found[k] for found in loops]
        run = None if mine is None else _run(study, job, xs[k], mine, share)
        if run is None:
            run, missed = run_job(job.payload()), missed + 1
        elif not all(loop.batched for loop in mine):
            alone += 1
        run["attempts"] = 1
        runs.append(run)
    return runs, (missed, alone)


def _drawn(value: float | list[float], condition: int | None) -> float:
    """A drawn value as one condition sees it (a per-condition parameter's entry)."""
    return float(value[condition] if isinstance(value, list) and condition is not None else value)


def _condition_loops(problem: Problem, c: int, jobs: Sequence) -> list[SampleLoop | None] | None:
    """Condition ``c``'s loop of every sample, margins found; None when it has no batch form."""
    condition = problem.conditions[c]
    columns = {name: np.full(len(jobs), value) for name, value in problem.condition_values(c).items()}
    for name in jobs[0].start:
        if name in columns:
            columns[name] = np.array([_drawn(job.start[name], c) for job in jobs])
    forms = batch_pole_zero(condition.network, condition.break_at, columns)
    return None if forms is None else batch_margins(forms)


def _run(study: _Study, job, x: np.ndarray, loops: list[SampleLoop | None], share: float) -> dict | None:
    """One sample's run as `run_job` makes it, from its conditions' loops; None when a row
    needs the per-loop path."""
    stepper = study.stepper
    values, frequencies = [], []
    for spec in stepper.specs:
        loop = loops[spec.condition]
        if loop is None:
            return None
        if spec.kind == "stability_abscissa":
            value, frequency = loop.abscissa, math.nan
        elif spec.kind == "crossover_frequency" and not any(
            spec.low <= m.frequency <= spec.high for m in loop.margins.phase
        ):
            return None  # its absence value reads the grid response: the per-loop path's
        else:
            value, frequency = frequency_value(spec, loop.margins, None)
        values.append(value)
        frequencies.append(frequency)
    point = stepper.point_at(x, np.array(values, dtype=float), np.array(frequencies, dtype=float))
    rows = [_row_json(fields) for fields in stepper.row_fields(point)]
    return {
        "index": job.index,
        "label": job.label,
        "start": job.start,
        "worker": "local",
        "status": "running",
        "reason": "",
        "iterations": 0,
        "parameters": {**study.named, **job.start},
        "ranking": point.merit,
        "measures": rows,
        "meets_requirements": all(row["satisfied"] for row in rows),
        "seconds": share,
    }


def _row_json(fields: tuple) -> dict:
    """A tableau row (its `MeasureRow` fields, in their order) as `StepRecord.to_json` writes it
    (non-finite numbers as 'inf', '-inf', 'nan')."""
    name, kind, condition, value, desired, satisfied, frequency, at_least, method = fields
    return {
        "name": name,
        "kind": kind,
        "condition": condition,
        "value": _number(value),
        "desired": _number(desired),
        "satisfied": satisfied,
        "frequency": _number(frequency),
        "at_least": at_least,
        "method": method,
    }


def _number(value: float | None) -> float | str | None:
    return value if value is None or math.isfinite(value) else repr(value)

"""Sweeps: many runs of one session on Dask (multi-start "map the hill",
penalty trade-offs, toleranced plants).  This module plans them: the jobs
(`Job`: data only, the session's JSON with its tables inlined) and the
one-line form the app asks for.  `sessions.sweeps.jobs` runs them,
`sessions.sweeps.results` makes the summary kept in the session.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, overload

import numpy as np

from sessions.build import read_csv, table_path
from sessions.errors import SessionError
from sessions.format.limits import MAX_STARTS
from sessions.lifecycle import bounds_holding, folder
from sessions.store import Session, tables_in
from sessions.sweeps.cluster import scheduler_address
from sessions.sweeps.jobs import run_job
from sessions.sweeps.sampling import SAMPLINGS, deviations, parse_tolerances


@dataclass(frozen=True)
class Job:
    """One run to ship: the session document and what makes this run different."""

    index: int
    label: str
    model: dict
    mode: str = "run"  # "run": the algorithm to its end; "evaluate": the tableau of the design
    start: dict = field(default_factory=dict)
    # a tolerance sample's study: the document every sample is but for the values drawn (``start``)
    # and their bounds (`sessions.sweeps.batch_study` evaluates the samples of one study together)
    study: dict | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        return {"index": self.index, "label": self.label, "model": self.model, "mode": self.mode, "start": self.start}


def shippable(session: Session, allow_outside_tables: bool | None = None) -> dict:
    """The session as JSON data with CSV tables inlined (read as `build_problem` reads
    them: none outside the session's folder unless allowed) and no records."""
    model = session.model.model_copy(deep=True)
    base = folder(session)
    for table in tables_in(model):
        if table.csv is not None:
            allowed = allow_outside_tables if allow_outside_tables is not None else session.allow_outside_tables or None
            file = table_path(base, table.csv, "table", allowed)
            f, first, second = read_csv(file, table.columns, "table")
            table.frequency, table.first, table.second = f, first, second or None
            table.csv, table.columns = None, None
    model.records, model.current_iteration, model.state, model.sweeps = [], 0, None, []
    return model.model_dump(mode="json")


def start_jobs(session: Session, starts: int, spread: float | None = None, seed: int = 0) -> list[Job]:
    """``starts`` runs from points drawn around the session's start: log-uniform within
    the bounds when both are positive and finite; with ``spread`` F (or unbounded),
    log-uniform in [x/F, x F] (F = 10 by default) clipped to the bounds."""
    if not 1 <= starts <= MAX_STARTS:  # each start a copy of the session, its run kept: memory bounded
        raise SessionError(f"--starts: {starts} is not in 1..{MAX_STARTS}")
    if spread is not None and spread <= 1:
        raise SessionError("--spread must exceed 1 (a factor)")
    base = shippable(session)
    rng = np.random.default_rng(seed)
    problem = session.problem
    jobs = []
    for k in range(starts):
        model = copy.deepcopy(base)
        start: dict[str, Any] = {}
        for entry, parameter in zip(model["problem"]["parameters"], problem.parameters):
            if not parameter.free:
                continue
            low, high = parameter.lower(), parameter.upper()
            values = entry["value"] if isinstance(entry["value"], list) else [entry["value"]]
            drawn = [_draw(rng, float(v), low, high, spread) for v in values]
            entry["value"] = drawn if isinstance(entry["value"], list) else drawn[0]
            start[parameter.name] = entry["value"]
        jobs.append(Job(k, f"start {k}", model, start=start))
    return jobs


def _draw(rng: np.random.Generator, value: float, low: float, high: float, spread: float | None) -> float:
    if spread is None and 0 < low < high < math.inf:
        return float(math.exp(rng.uniform(math.log(low), math.log(high))))
    factor = spread or 10.0
    if value == 0:
        lo, hi = max(low, -1.0), min(high, 1.0)
        return float(rng.uniform(lo, hi))
    return float(np.clip(value * math.exp(rng.uniform(-math.log(factor), math.log(factor))), low, high))


def vary_jobs(session: Session, assignment: str) -> list[Job]:
    """One run per value of NAME=V1,V2,...: NAME an objective option (a penalty), a
    parameter's value, or a path into the problem (targets[0].bands[0].desired).
    Every run starts from the session's design: its current iteration's, or, with
    no iteration yet, the end of a run of the session as it is (made here first),
    so the sweep traces the trade-off around one design (report 001, Figure 4)
    rather than wherever each run stalls from a far start."""
    name, sep, text = assignment.partition("=")
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise SessionError(f"--vary {assignment!r}: values must be numbers, V1,V2,...") from None
    if not sep or not values:
        raise SessionError(f"--vary {assignment!r}: write NAME=V1,V2,...")
    shipped = shippable(session)
    design = _current_design(session)
    if not design:
        first = run_job(Job(-1, "design", shipped).payload())
        if first["status"] == "failed":
            raise SessionError(f"--vary: the session's own run failed: {first['reason']}")
        design = first["parameters"]
    base = _with_design(shipped, design)
    jobs = []
    for k, value in enumerate(values):
        model = copy.deepcopy(base)
        _assign(model["problem"], name.strip(), value)
        jobs.append(Job(k, f"{name.strip()}={value:g}", model, start={name.strip(): value}))
    return jobs


def _assign(problem: dict, name: str, value: float) -> None:
    objective = problem.get("objective") or {}
    if name in objective.get("options", {}):
        objective["options"][name] = value
        return
    for parameter in problem["parameters"]:
        if parameter["name"] == name:
            parameter["value"] = [value] * len(parameter["value"]) if isinstance(parameter["value"], list) else value
            return
    node: Any = problem
    parts = name.replace("]", "").replace("[", ".").split(".")
    try:
        for part in parts[:-1]:
            node = node[int(part)] if isinstance(node, list) else node[part]
        last = parts[-1]
        if isinstance(node, list):
            node[int(last)] = value
        elif last in node:
            node[last] = value
        else:
            raise KeyError(last)
    except (KeyError, IndexError, ValueError, TypeError):
        raise SessionError(
            f"--vary {name!r}: not an objective option, a parameter, or a path in the problem "
            "(e.g. targets[0].bands[0].desired)"
        ) from None


def tolerance_jobs(
    session: Session, tolerances: Sequence[str], samples: int, seed: int = 0, sampling: str = "random"
) -> ToleranceSamples:
    """Monte Carlo over the parameters' laws (`sessions.sweeps.sampling`: NAME=+-P%
    uniform, NAME=normal:P% normal; drawn at random or by Latin hypercube) about the
    session's current design; each job evaluates the tableau (no optimization) at the
    drawn values, whatever the design's bounds and constraints (they limit the designer's
    choices, not the parts' spread: a sample's bounds are widened to hold it, the linear
    constraints and equalities between parameters left out).  The jobs are made when
    read (`ToleranceSamples`)."""
    laws = parse_tolerances(tolerances)
    base = _with_design(shippable(session), _current_design(session))
    # a sample is the hardware as built: the constraints between parameters limit the designer's choices
    base["problem"]["constraints"], base["problem"]["equalities"] = [], []
    entries = {p["name"]: p for p in base["problem"]["parameters"]}
    unknown = sorted(set(laws) - set(entries))
    if unknown:
        raise SessionError(f"--tolerance: no parameter {', '.join(unknown)} (parameters: {', '.join(sorted(entries))})")
    names = [name for name in entries if name in laws]  # the session's order: a seed draws as it always did
    sizes = [len(entries[name]["value"]) if isinstance(entries[name]["value"], list) else 1 for name in names]
    drawn = deviations([laws[name] for name in names], sizes, samples, sampling, seed)
    return ToleranceSamples(base, dict(zip(names, drawn)), range(samples))


class ToleranceSamples(Sequence[Job]):
    """A tolerance study's jobs, each made when it is read (a slice is a view): the study's
    document and every sample's drawn deviations as arrays, a few bytes a sample, where
    100 000 jobs held at once took 157 MB.  `columns` gives a chunk's drawn values without
    making its jobs (`sessions.sweeps.batch_study`)."""

    def __init__(self, base: dict, deviations: dict[str, np.ndarray], indices: range, first_row: int = 0) -> None:
        self.base = base  # the document every sample is but for its drawn values and their bounds
        # name -> (samples, values) relative deviations: every sample's of the study from sample ``first_row`` on
        self.deviations = deviations
        self.indices = indices  # the samples of this view
        self.first_row = first_row  # the sample of the deviations' first row (`shipped`)

    def __len__(self) -> int:
        return len(self.indices)

    @overload
    def __getitem__(self, key: int) -> Job: ...
    @overload
    def __getitem__(self, key: slice) -> ToleranceSamples: ...
    def __getitem__(self, key: int | slice) -> Job | ToleranceSamples:
        if isinstance(key, slice):
            return ToleranceSamples(self.base, self.deviations, self.indices[key], self.first_row)
        k = self.indices[key]
        return _sample(self.base, k, {name: d[k - self.first_row] for name, d in self.deviations.items()})

    def shipped(self) -> ToleranceSamples:
        """This view holding only its own samples' deviations (what a cluster's worker is sent:
        a chunk of a study of a million samples is not sent every sample's draws); the view's
        samples are consecutive."""
        rows = slice(self.indices.start - self.first_row, self.indices.stop - self.first_row)
        return ToleranceSamples(
            self.base, {name: d[rows] for name, d in self.deviations.items()}, self.indices, self.indices.start
        )

    def columns(self) -> dict[str, np.ndarray]:
        """Each drawn parameter's values over the samples, as `_sample` computes them: (samples,),
        or (samples, conditions) for a parameter with a value per condition (each job's ``start`` as arrays)."""
        entries = {entry["name"]: entry["value"] for entry in self.base["problem"]["parameters"]}
        rows = np.asarray(self.indices, dtype=np.intp) - self.first_row
        return {name: _values(entries[name], 1 + d[rows]) for name, d in self.deviations.items()}


def _values(value: float | list[float], scales: np.ndarray) -> np.ndarray:
    """A parameter's value times each row of ``scales`` as `_sample` computes it: one per row, or a row per condition."""
    if isinstance(value, list):
        return np.asarray(value) * scales
    return value * scales[:, 0]


def _sample(base: dict, k: int, deviation: dict[str, np.ndarray]) -> Job:
    """The job of sample ``k``: each named parameter's value times 1 + its deviation.  Only the
    drawn parameters are the sample's own: the rest of the document is the base's, shared by every
    sample and never written (a deep copy each took 1.4 s and 54 MB to plan 10 000 samples)."""
    problem = base["problem"]
    entries = [dict(entry) if entry["name"] in deviation else entry for entry in problem["parameters"]]
    model = {**base, "problem": {**problem, "parameters": entries}}
    drawn = {}
    for entry in model["problem"]["parameters"]:
        if entry["name"] in deviation:
            value, scale = entry["value"], 1 + deviation[entry["name"]]
            value = (np.asarray(value) * scale).tolist() if isinstance(value, list) else float(value * scale[0])
            entry["value"] = drawn[entry["name"]] = value
            # a sample is evaluated at its value: the design bounds limit the optimizer, not the physics
            entry["min"], entry["max"], _ = bounds_holding(entry["name"], entry.get("min"), entry.get("max"), value)
    return Job(k, f"sample {k}", model, mode="evaluate", start=drawn, study=base)


def _with_design(model: dict, design: dict) -> dict:
    """The document with its parameters set to a design (name -> value)."""
    for entry in model["problem"]["parameters"]:
        if entry["name"] in design:
            entry["value"] = design[entry["name"]]
    return model


def _current_design(session: Session) -> dict:
    k = session.model.current_iteration
    return dict(session.records[k - 1].parameters) if k else {}


def plan(
    session: Session,
    kind: str,
    value,
    spread: float | None = None,
    seed: int = 0,
    samples: int = 32,
    sampling: str = "random",
) -> tuple[list[Job], dict]:
    """The jobs of a sweep and the settings it is recorded with: ``kind`` "starts"
    (value: how many), "vary" (value: NAME=V1,V2,...) or "tolerance" (value: a list
    of NAME=+-P% or NAME=normal:P%, drawn by ``sampling``, random or lhs)."""
    if kind == "starts":
        return start_jobs(session, int(value), spread, seed), {"starts": int(value), "spread": spread, "seed": seed}
    if kind == "vary":
        return vary_jobs(session, value), {"vary": value}
    if kind == "tolerance":
        return (
            tolerance_jobs(session, list(value), samples, seed, sampling),
            {"tolerance": list(value), "samples": samples, "seed": seed, "sampling": sampling},
        )
    raise SessionError(f"unknown sweep {kind!r}: starts, vary or tolerance")


def parse_sweep(text: str) -> dict:
    """'starts 16 [spread 2] [seed 3]', 'vary q2=0,1e-4', 'tolerance T1=+-10% T2=normal:5%
    [samples 20] [sampling lhs] [seed 3]', each optionally ending 'at tcp://HOST:PORT' ->
    keyword arguments of `plan` and ``scheduler``."""
    words = text.split()
    if not words or words[0] not in ("starts", "vary", "tolerance"):
        raise SessionError("begin with starts, vary or tolerance")
    out: dict = {"kind": words[0], "scheduler": None}
    rest = words[1:]
    if "at" in rest:
        k = rest.index("at")
        if k + 1 >= len(rest):
            raise SessionError("'at' needs a scheduler address (tcp://HOST:PORT)")
        out["scheduler"], rest = scheduler_address(rest[k + 1], "at"), rest[:k] + rest[k + 2 :]
    options = {"spread": float, "seed": int, "samples": int, "sampling": _sampling}
    values = []
    while rest:
        word = rest.pop(0)
        if word in options:
            if not rest:
                raise SessionError(f"{word!r} needs a value")
            try:
                out[word] = options[word](rest.pop(0))
            except SessionError:  # (a ValueError too) sampling's own
                raise
            except ValueError:
                raise SessionError(f"{word}: not a number") from None
        else:
            values.append(word)
    if not values:
        raise SessionError(f"{out['kind']}: say what (e.g. 'starts 16', 'vary q2=0,1e-4', 'tolerance T1=+-10%')")
    if out["kind"] == "starts":
        try:
            out["value"] = int(values[0])
        except ValueError:
            raise SessionError(f"starts {values[0]!r}: a number of runs") from None
    elif out["kind"] == "vary":
        out["value"] = values[0]
    else:
        parse_tolerances(values)  # a law mistyped is said in the dialog, before any run
        out["value"] = values
    return out


def _sampling(word: str) -> str:
    if word not in SAMPLINGS:
        raise SessionError(f"sampling {word!r}: random or lhs")
    return word

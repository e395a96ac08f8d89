"""Sweeps: many runs of one session on Dask (issue: "map the hill", penalty
trade-offs, toleranced plants).

What is shipped to a worker is data only: the session's JSON document (its
CSV tables inlined, so a remote worker needs no files) and a job number; the
worker runs `run_job`, a function of this module that workers import (they
need loopcraft installed), and sends back plain JSON (the final StepRecord's
content).  Without an address a local cluster is started with one process
per core, one thread each; with ``tcp://HOST:PORT`` that cluster is used.

A job that fails (a singular matrix, a worker that dies twice) is recorded
as failed with its reason; the sweep goes on.  Each job logs a "started"
event on the scheduler, so a job that had to be restarted on another worker
is reported with its attempts.
"""

from __future__ import annotations

import copy
import math
import os
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from engine.algorithm import Status, StepRecord, iterate, lookup, make_settings
from engine.errors import EngineError
from engine.loops import open_loop
from engine.measures import tableau
from engine.problem import Problem

from .build import build_problem, read_csv
from .errors import SessionError
from .schema import SessionModel, SweepModel
from .runner import adopt_parameters
from .store import Session, now, tables_in

SWEEP_VERSION = 1
MAX_ITERATIONS = 1000
EVENT_TOPIC = "loopcraft-sweep"
SAME_PARAMETERS = 0.05     # decades (about 12 %): runs closer than this in every parameter share an optimum
SAME_LOOP = 0.01           # runs whose open loops agree within 1 % at every signature point share an optimum
SIGNATURE_POINTS = 24      # frequencies (grid points spread over the grid) of a run's loop signature
SAME_OBJECTIVE = 0.01      # relative


@dataclass(frozen=True)
class Job:
    """One run to ship: the session document and what makes this run different."""

    index: int
    label: str
    model: dict
    mode: str = "run"      # "run": the algorithm to its end; "evaluate": the tableau of the design
    start: dict = field(default_factory=dict)

    def payload(self) -> dict:
        return {"index": self.index, "label": self.label, "model": self.model, "mode": self.mode,
                "start": self.start}


# -- planning ------------------------------------------------------------------

def shippable(session: Session) -> dict:
    """The session as JSON data with CSV tables inlined and no records."""
    model = session.model.model_copy(deep=True)
    folder = session.path.parent if session.path else Path.cwd()
    for table in tables_in(model):
        if table.csv is not None:
            f, first, second = read_csv(folder / table.csv, table.columns, "table")
            table.frequency, table.first, table.second = f, first, second or None
            table.csv, table.columns = None, None
    model.records, model.current_iteration, model.state, model.sweeps = [], 0, None, []
    return model.model_dump(mode="json")


def start_jobs(session: Session, starts: int, spread: float | None = None, seed: int = 0) -> list[Job]:
    """``starts`` runs from points drawn around the session's start: log-uniform within
    the bounds when both are positive and finite; with ``spread`` F (or unbounded),
    log-uniform in [x/F, x F] (F = 10 by default) clipped to the bounds."""
    if starts < 1:
        raise SessionError("--starts must be at least 1")
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
        raise SessionError(f"--vary {name!r}: not an objective option, a parameter, or a path in the problem "
                           "(e.g. targets[0].bands[0].desired)") from None


def tolerance_jobs(session: Session, tolerances: Sequence[str], samples: int, seed: int = 0) -> list[Job]:
    """Monte Carlo over NAME=+-P% (uniform within +-P % of each value) at the
    session's current design; each job evaluates the tableau (no optimization)."""
    spreads = {}
    for text in tolerances:
        name, sep, amount = text.partition("=")
        amount = amount.strip().removeprefix("+-").removeprefix("±")
        try:
            fraction = float(amount.removesuffix("%")) / (100.0 if amount.endswith("%") else 1.0)
        except ValueError:
            raise SessionError(f"--tolerance {text!r}: write NAME=+-10%") from None
        if not sep or fraction < 0:
            raise SessionError(f"--tolerance {text!r}: write NAME=+-10%")
        spreads[name.strip()] = fraction
    base = _with_design(shippable(session), _current_design(session))
    known = {p["name"] for p in base["problem"]["parameters"]}
    unknown = sorted(set(spreads) - known)
    if unknown:
        raise SessionError(f"--tolerance: no parameter {', '.join(unknown)} (parameters: {', '.join(sorted(known))})")
    rng = np.random.default_rng(seed)
    jobs = []
    for k in range(samples):
        model = copy.deepcopy(base)
        drawn = {}
        for entry in model["problem"]["parameters"]:
            if entry["name"] in spreads:
                f, value = spreads[entry["name"]], entry["value"]
                scale = (1 + rng.uniform(-f, f, len(value))) if isinstance(value, list) else 1 + rng.uniform(-f, f)
                value = (np.asarray(value) * scale).tolist() if isinstance(value, list) else float(value * scale)
                entry["value"] = drawn[entry["name"]] = value
        jobs.append(Job(k, f"sample {k}", model, mode="evaluate", start=drawn))
    return jobs


def _with_design(model: dict, design: dict) -> dict:
    """The document with its parameters set to a design (name -> value)."""
    for entry in model["problem"]["parameters"]:
        if entry["name"] in design:
            entry["value"] = design[entry["name"]]
    return model


def _current_design(session: Session) -> dict:
    k = session.model.current_iteration
    return dict(session.records[k - 1].parameters) if k else {}


def plan(session: Session, kind: str, value, spread: float | None = None, seed: int = 0,
         samples: int = 32) -> tuple[list[Job], dict]:
    """The jobs of a sweep and the settings it is recorded with: ``kind`` "starts"
    (value: how many), "vary" (value: NAME=V1,V2,...) or "tolerance" (value: a list
    of NAME=+-P%)."""
    if kind == "starts":
        return start_jobs(session, int(value), spread, seed), {"starts": int(value), "spread": spread, "seed": seed}
    if kind == "vary":
        return vary_jobs(session, value), {"vary": value}
    if kind == "tolerance":
        return (tolerance_jobs(session, list(value), samples, seed),
                {"tolerance": list(value), "samples": samples, "seed": seed})
    raise SessionError(f"unknown sweep {kind!r}: starts, vary or tolerance")


def parse_sweep(text: str) -> dict:
    """'starts 16 [spread 2] [seed 3]', 'vary q2=0,1e-4', 'tolerance T1=+-10% [samples 20]',
    each optionally ending 'at tcp://HOST:PORT' -> keyword arguments of `plan` and ``scheduler``."""
    words = text.split()
    if not words or words[0] not in ("starts", "vary", "tolerance"):
        raise SessionError("begin with starts, vary or tolerance")
    out: dict = {"kind": words[0], "scheduler": None}
    rest = words[1:]
    if "at" in rest:
        k = rest.index("at")
        if k + 1 >= len(rest):
            raise SessionError("'at' needs a scheduler address (tcp://HOST:PORT)")
        out["scheduler"], rest = rest[k + 1], rest[:k] + rest[k + 2:]
    options = {"spread": float, "seed": int, "samples": int}
    values = []
    while rest:
        word = rest.pop(0)
        if word in options:
            if not rest:
                raise SessionError(f"{word!r} needs a value")
            try:
                out[word] = options[word](rest.pop(0))
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
    else:
        out["value"] = values[0] if out["kind"] == "vary" else values
    return out


# -- on a worker -------------------------------------------------------------

def run_job(payload: dict) -> dict:
    """Run (or evaluate) one job; never raises: a failure is a result."""
    began = time.perf_counter()
    worker = _announce(payload["index"])
    result = {"index": payload["index"], "label": payload["label"], "start": payload["start"], "worker": worker}
    try:
        model = SessionModel.model_validate(payload["model"])
        problem = build_problem(model.problem, Path.cwd())
        registration = lookup(model.algorithm.name)
        algorithm = registration.factory()
        settings = make_settings(model.algorithm.name, model.algorithm.settings)
        if payload["mode"] == "evaluate":
            record = _evaluate(algorithm, problem, settings)
        else:
            record = None
            for _, record in iterate(algorithm, problem, settings, max_iter=MAX_ITERATIONS):
                pass
            if record is None:
                raise SessionError("the algorithm made no iteration")
        result.update(_summary(record))
        if payload["mode"] != "evaluate":
            result["signature"] = loop_signature(problem, record.parameters)
    except Exception as exc:  # noqa: BLE001 - a run's failure is data, never the sweep's end
        result.update(status="failed", reason=f"{type(exc).__name__}: {exc}", parameters={}, objective=None,
                      measures=[], meets_requirements=False, iterations=0)
    result["seconds"] = time.perf_counter() - began
    return result


def _evaluate(algorithm, problem, settings) -> StepRecord:
    state = algorithm.init(problem, settings)
    if hasattr(algorithm, "initial_record"):
        return algorithm.initial_record(state)
    return StepRecord(0, Status.RUNNING, problem.named_values(), tuple(tableau(problem)))


def _summary(record: StepRecord) -> dict:
    objective = record.objective if record.objective is not None else record.extra.get("smallest_stability_margin")
    out = {"status": record.status.value, "reason": record.reason, "iterations": record.iteration,
           "parameters": dict(record.parameters), "objective": objective,
           "measures": record.to_json()["measures"],
           "meets_requirements": all(m.satisfied for m in record.measures)}
    if "averaged_squares" in record.extra:
        out["averaged_squares"] = dict(record.extra["averaged_squares"])
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
            gh = open_loop(condition.network, condition.break_at, omega, problem.values_with(parameters, k),
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


def execute(jobs: Sequence[Job], scheduler: str | None = None, workers: int | None = None,
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


def _lost(job: Job, exc: BaseException) -> dict:
    kind = type(exc).__name__
    reason = "cancelled" if kind == "CancelledError" else f"{kind}: {exc}"
    return {"index": job.index, "label": job.label, "start": job.start, "worker": None, "status": "failed",
            "reason": reason, "parameters": {}, "objective": None, "measures": [], "meets_requirements": False,
            "iterations": 0, "seconds": None}


def execute_serial(jobs: Sequence[Job], progress: Callable[[int, int], None] | None = None) -> Outcome:
    """The same jobs in this process, one after the other (the throughput baseline)."""
    runs = []
    for job in jobs:
        runs.append(run_job(job.payload()))
        runs[-1]["attempts"] = 1
        if progress:
            progress(len(runs), len(jobs))
    return Outcome(runs, 1, {})


# -- results -----------------------------------------------------------------

def optima(runs: Sequence[dict], maximize: bool) -> list[dict]:
    """Distinct local optima: runs whose open loops agree within 1 % at every
    signature point (`loop_signature`; without signatures, whose final
    parameters agree within about 12 % in every parameter, log scale, linear
    near zero) and whose objectives agree within 1 %; each with its count
    and best run."""
    done = [r for r in runs if r["status"] != "failed" and r["parameters"]]
    sign = -1.0 if maximize else 1.0

    def rank(r: dict) -> tuple:
        objective = r["objective"] if isinstance(r["objective"], (int, float)) else math.inf
        return (not r["meets_requirements"], sign * objective if math.isfinite(objective) else math.inf)
    clusters: list[dict] = []
    for run in sorted(done, key=rank):
        vector, signature = _vector(run["parameters"]), _signature(run)
        for cluster in clusters:
            same = _same_loop(signature, cluster["signature"]) if signature is not None and \
                cluster["signature"] is not None else _near(vector, cluster["vector"])
            if same and _close(run["objective"], cluster["objective"]):
                cluster["runs"].append(run["index"])
                break
        else:
            clusters.append({"vector": vector, "signature": signature, "objective": run["objective"],
                             "parameters": run["parameters"],
                             "meets_requirements": run["meets_requirements"], "best_run": run["index"],
                             "runs": [run["index"]]})
    return [{"parameters": c["parameters"], "objective": c["objective"], "count": len(c["runs"]),
             "meets_requirements": c["meets_requirements"], "best_run": c["best_run"], "runs": c["runs"]}
            for c in clusters]


def _signature(run: dict) -> np.ndarray | None:
    pairs = run.get("signature")
    return None if not pairs else np.array([complex(re, im) for re, im in pairs])


def _same_loop(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and bool(np.all(np.abs(a - b) <= SAME_LOOP * np.maximum(np.abs(a), np.abs(b))))


def _vector(parameters: dict) -> np.ndarray:
    values = []
    for name in sorted(parameters):
        v = parameters[name]
        values += v if isinstance(v, list) else [v]
    return np.array(values, dtype=float)


def _near(a: np.ndarray, b: np.ndarray) -> bool:
    if a.shape != b.shape:
        return False
    positive = (a > 0) & (b > 0)
    logs = np.abs(np.log10(a[positive]) - np.log10(b[positive])) <= SAME_PARAMETERS
    scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-12)
    linear = np.abs(a - b)[~positive] <= 0.12 * scale[~positive]
    return bool(np.all(logs) and np.all(linear))


def _close(a, b) -> bool:
    if not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
        return a == b
    return abs(a - b) <= SAME_OBJECTIVE * max(abs(a), abs(b)) + 1e-12


def worst_case(runs: Sequence[dict]) -> list[dict]:
    """Per measure row (name, kind, condition): the worst value over the samples."""
    table: dict[tuple, dict] = {}
    for run in runs:
        for m in run["measures"]:
            value = m["value"] if isinstance(m["value"], (int, float)) else float(m["value"])
            key = (m["name"], m["kind"], m["condition"])
            row = table.setdefault(key, {"name": m["name"], "kind": m["kind"], "condition": m["condition"],
                                         "target": m["target"], "worst": value, "worst_sample": run["index"],
                                         "unmet_samples": 0, "samples": 0})
            row["samples"] += 1
            row["unmet_samples"] += not m["satisfied"]
            worse = value < row["worst"] if m["at_least"] else value > row["worst"]
            if math.isnan(row["worst"]) or worse:
                row["worst"], row["worst_sample"] = value, run["index"]
    return list(table.values())


def summarize(session: Session, kind: str, settings: dict, outcome: Outcome) -> dict:
    """The sweep as saved in the session and printed by --json."""
    maximize = lookup(session.model.algorithm.name).maximize
    data = {"version": SWEEP_VERSION, "kind": kind, "created": now(), "algorithm": session.model.algorithm.name,
            "settings": settings, "workers": outcome.workers, "cancelled": outcome.cancelled,
            "runs": outcome.runs, "failed": [r["index"] for r in outcome.runs if r["status"] == "failed"],
            "retried": {str(k): v for k, v in outcome.attempts.items() if len(v) > 1}}
    if kind == "tolerance":
        data["worst_case"] = worst_case([r for r in outcome.runs if r["status"] != "failed"])
        data["optima"] = []
    else:
        data["optima"] = optima(outcome.runs, maximize)
    for run in outcome.runs:
        run.pop("signature", None)  # only for clustering: not kept in the session
    return data


def record_sweep(session: Session, summary: dict) -> None:
    """Keep the sweep in the session's `sweeps` section."""
    session.model.sweeps.append(SweepModel.model_validate(summary))


def adopt_run(session: Session, run: dict) -> None:
    """Make a run's final parameters the session's start (records are cleared)."""
    if not run.get("parameters"):
        raise SessionError(f"run {run['index']} has no parameters to adopt ({run['status']})")
    adopt_parameters(session, run["parameters"])

"""A sweep's results: distinct local optima, the worst case of a tolerance
study, the summary kept in the session, and adopting a run's design."""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from engine.design.notes import at_bounds
from engine.stepping.memory_fields import jsonable
from engine.stepping.registry import lookup
from sessions.errors import SessionError
from sessions.format.schema import SweepModel
from sessions.lifecycle import adopt_parameters
from sessions.store import Session, now
from sessions.sweeps.dispersion import Tally, worst_row
from sessions.sweeps.jobs import Outcome

SWEEP_VERSION = 2
SAME_PARAMETERS = 0.05  # decades (about 12 %): runs closer than this in every parameter share an optimum
SAME_LOOP = 0.01  # runs whose open loops agree within 1 % at every signature point share an optimum
SAME_OBJECTIVE = 0.01  # relative


def optima(runs: Sequence[dict], maximize: bool) -> list[dict]:
    """Distinct local optima: runs whose open loops agree within 1 % at every
    signature point (`loop_signature`; without signatures, whose final
    parameters agree within about 12 % in every parameter, log scale, linear
    near zero) and whose ranking values agree within 1 %; each with its count
    and best run."""
    done = [r for r in runs if r["status"] != "failed" and r["parameters"]]
    sign = -1.0 if maximize else 1.0

    def rank(r: dict) -> tuple:
        ranking = r["ranking"] if isinstance(r["ranking"], (int, float)) else math.inf
        return (not r["meets_requirements"], sign * ranking if math.isfinite(ranking) else math.inf)

    clusters: list[dict] = []
    for run in sorted(done, key=rank):
        vector, signature = _vector(run["parameters"]), _signature(run)
        for cluster in clusters:
            same = (
                _same_loop(signature, cluster["signature"])
                if signature is not None and cluster["signature"] is not None
                else _near(vector, cluster["vector"])
            )
            if same and _close(run["ranking"], cluster["ranking"]):
                cluster["runs"].append(run["index"])
                break
        else:
            clusters.append(
                {
                    "vector": vector,
                    "signature": signature,
                    "ranking": run["ranking"],
                    "parameters": run["parameters"],
                    "meets_requirements": run["meets_requirements"],
                    "best_run": run["index"],
                    "runs": [run["index"]],
                }
            )
    return [
        {
            "parameters": c["parameters"],
            "ranking": c["ranking"],
            "count": len(c["runs"]),
            "meets_requirements": c["meets_requirements"],
            "best_run": c["best_run"],
            "runs": c["runs"],
        }
        for c in clusters
    ]


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
    """Per measure row (name, kind, condition): the worst value over the samples, the
    sample it is of, and how many samples miss the desired value."""
    return Tally.of(runs).worst_case()


def save_samples(path: Path, session: Session, settings: dict, outcome: Outcome) -> Path:
    """A tolerance study's every sample as arrays in ``path`` (numpy's .npz): each drawn
    parameter's values ("parameter/NAME", one per sample, or per sample and condition), the
    counted samples ("index"; failed ones are in the summary) and each row's values aligned
    with them ("row/NAME@CONDITION").  The draws are made again from the study's settings
    (`plan.tolerance_jobs` replays a seed exactly): nothing per sample is kept for it."""
    from sessions.sweeps.plan import tolerance_jobs

    samples = tolerance_jobs(
        session, settings["tolerance"], settings["samples"], settings["seed"], settings["sampling"]
    )
    entries = {entry["name"]: entry["value"] for entry in samples.base["problem"]["parameters"]}
    arrays = {
        f"parameter/{name}": np.asarray(entries[name], dtype=float) * (1 + deviation)
        if isinstance(entries[name], list)
        else entries[name] * (1 + deviation[:, 0])
        for name, deviation in samples.deviations.items()
    }
    tally = outcome.tally or Tally.of(outcome.runs)
    values = tally.sample_values()
    arrays["index"] = values.pop("index")
    arrays |= {f"row/{key}": column for key, column in values.items()}
    with open(path, "wb") as out:
        np.savez(out, **arrays)
    return path


def summarize(session: Session, kind: str, settings: dict, outcome: Outcome) -> dict:
    """The sweep as saved in the session and printed by --json (its settings with the
    outcome's: "scheduler" serial when the runs were made here, and its note)."""
    maximize = lookup(session.model.algorithm.name).presenter.maximize
    tally = (outcome.tally or Tally.of(outcome.runs)) if kind == "tolerance" else None
    note = outcome.note
    if tally is not None and tally.note and tally.note not in note:
        note = f"{note}; {tally.note}" if note else tally.note
    settings = {
        **settings,
        **({"scheduler": "serial"} if outcome.serial else {}),
        **({"note": note} if note else {}),
        **({"runs_kept": len(tally.runs())} if tally is not None and tally.thinned else {}),
    }
    data = {
        "version": SWEEP_VERSION,
        "kind": kind,
        "created": now(),
        "algorithm": session.model.algorithm.name,
        "settings": settings,
        "workers": outcome.workers,
        "cancelled": outcome.cancelled,
        "runs": outcome.runs,
        "failed": [r["index"] for r in outcome.runs if r["status"] == "failed"],
        "retried": {str(k): v for k, v in outcome.attempts.items() if len(v) > 1},
    }
    if tally is not None:  # a tolerance study: its rows from the tally; the runs it kept
        data.update(
            runs=tally.runs(),
            failed=list(tally.failed),
            excluded=dict(tally.excluded.most_common()),
            worst_case=tally.rows(),
            optima=[],
        )
    else:
        data["optima"] = [
            {**o, "notes": at_bounds(session.problem, o["parameters"])} for o in optima(outcome.runs, maximize)
        ]
    for run in outcome.runs:
        run.pop("signature", None)  # only for clustering: not kept in the session
    return jsonable(data)  # infinities and NaN as "inf", "nan": the session's JSON has no others


def recovery_path(target: Path) -> Path:
    """Where a sweep's summary goes when its session cannot be saved: NAME.sweep-recovery.json beside it."""
    return target.with_name(f"{target.stem}.sweep-recovery.json")


def write_recovery(summary: dict, target: Path) -> Path:
    """Write a sweep's summary beside ``target`` (or, failing that, in the temporary
    folder) so that no result is lost; the file written, or a `SessionError`."""
    text = json.dumps({"session": str(target), "sweep": summary}, indent=2, sort_keys=True, allow_nan=False) + "\n"
    tried = []
    for place in (recovery_path(target), Path(tempfile.gettempdir()) / recovery_path(target).name):
        try:
            _write_new(place, text)
            return place
        except OSError as exc:
            tried.append(f"{place}: {exc.strerror or exc}")
    raise SessionError("cannot write the sweep's recovery file (" + "; ".join(tried) + ")")


def _write_new(place: Path, text: str) -> None:
    """Write ``text`` to a temporary file beside ``place`` and rename it there."""
    fd, tmp = tempfile.mkstemp(prefix=f".{place.name}.", suffix=".tmp", dir=place.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, place)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def record_sweep(session: Session, summary: dict) -> None:
    """Keep the sweep in the session's `sweeps` section."""
    session.model.sweeps.append(SweepModel.model_validate(summary))


def adopt_run(session: Session, run: dict) -> list[str]:
    """Make a run's final parameters (a sample's values) the session's start (records are
    cleared); the design bounds widened to hold them, one line each."""
    if not run.get("parameters"):
        raise SessionError(f"run {run['index']} has no parameters to adopt ({run['status']})")
    return adopt_parameters(session, run["parameters"])


def adopt_worst(session: Session, sweep: dict, which: str | None = None) -> tuple[dict, dict, list[str]]:
    """Make a tolerance study's worst sample the session's start, to look at (records
    are cleared): the worst sample of the row ``which`` names (MEASURE or
    MEASURE@CONDITION), else of the row that misses its desired value by the most
    (`sessions.sweeps.dispersion.worst_row`).  (The row, the sample's run, the lines
    saying which bounds were widened.)"""
    if sweep["kind"] != "tolerance":
        raise SessionError(f"a {sweep['kind']} sweep has no worst sample (a tolerance study has)")
    row = worst_row(sweep["worst_case"], which)
    run = next(r for r in sweep["runs"] if r["index"] == row["worst_sample"])
    return row, run, adopt_run(session, run)

"""A tolerance study evaluated as a batch (issue 41, section 1): every sample's run is
the per-loop path's (`run_job`), its margins equal to 1e-12 relative; samples the batch
cannot certify go per loop, alone, and the study's note counts them; a loop with a delay
stays per loop whole; `sweep --serial` says what it did."""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest

from sessions.store import load_session
from sessions.sweeps.batch_study import batch_runs
from sessions.sweeps.jobs import execute, execute_serial, run_job
from sessions.sweeps.plan import plan
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
TOLERANCES = ["T1=+-10%", "T2=+-10%"]


def _session(tmp_path: Path, plant: str | None = None) -> Path:
    """The lag-lead example, its plant replaced when given."""
    model = json.loads((EXAMPLES / "coebra_lag_lead.json").read_text())
    if plant is not None:
        model["problem"]["conditions"][0]["plant"]["blocks"][1]["transfer"]["expression"] = plant
    path = tmp_path / "study.json"
    path.write_text(json.dumps(model))
    return path


def _same_run(batch: dict, loop: dict) -> None:
    assert set(batch) == set(loop) | {"attempts"}
    for key in loop:
        if key not in ("seconds", "measures", "ranking"):
            assert batch[key] == loop[key], key
    assert batch["ranking"] == pytest.approx(loop["ranking"], rel=1e-12)
    for got, want in zip(batch["measures"], loop["measures"], strict=True):
        assert {k: v for k, v in got.items() if k not in ("value", "frequency")} == {
            k: v for k, v in want.items() if k not in ("value", "frequency")
        }
        exact = 1e-9 if got["kind"] == "stability_abscissa" else 1e-12  # eigenvalues of other matrices
        for key in ("value", "frequency"):
            if isinstance(want[key], float):
                assert got[key] == pytest.approx(want[key], rel=exact), (got["name"], key)
            else:
                assert got[key] == want[key], (got["name"], key)


def _jobs(path: Path, samples: int, tolerances: list[str] = TOLERANCES) -> list:
    return plan(load_session(path), "tolerance", tolerances, None, 3, samples)[0]


def test_the_lag_lead_study_equals_the_per_loop_path(tmp_path):
    jobs = _jobs(_session(tmp_path), 150)
    batch = batch_runs(jobs)
    assert batch is not None and batch.per_loop == 0
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))
    assert batch.note.startswith(f"{150 - batch.searched} of 150 samples evaluated as a batch")


def test_a_sample_the_batch_leaves_goes_per_loop_alone(tmp_path):
    """Sample 2 draws T1 = T3 (its compensator's zero cancels a pole, which the per-loop path
    cancels): it alone runs per loop; every run equals run_job's."""
    jobs = _jobs(_session(tmp_path), 5)
    odd = copy.deepcopy(jobs[2].model)
    odd["problem"]["parameters"][0]["value"] = 10.0
    jobs[2] = type(jobs[2])(2, jobs[2].label, odd, jobs[2].mode, {**jobs[2].start, "T1": 10.0})
    batch = batch_runs(jobs)
    assert batch is not None and (batch.per_loop, batch.searched) == (1, 0)
    assert "4 of 5 samples evaluated as a batch" in batch.note
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


def test_a_loop_with_a_delay_stays_per_loop(tmp_path):
    path = _session(tmp_path)
    model = json.loads(path.read_text())
    plant = model["problem"]["conditions"][0]["plant"]
    plant["blocks"][1]["output"] = "yd"
    plant["blocks"].append({"input": "yd", "name": "delay", "output": "y", "transfer": {"kind": "delay", "tau": 0.002}})
    path.write_text(json.dumps(model))
    jobs = _jobs(path, 4)
    assert batch_runs(jobs) is None
    outcome = execute_serial(jobs)
    assert outcome.note == ""
    assert [run["status"] for run in outcome.runs] == ["running"] * 4


def test_a_sample_that_is_not_of_the_study_keeps_the_study_per_loop(tmp_path):
    jobs = _jobs(_session(tmp_path), 3)
    odd = copy.deepcopy(jobs[1].model)
    odd["problem"]["targets"][0]["bands"][0]["desired"] = 11.0
    jobs[1] = type(jobs[1])(jobs[1].index, jobs[1].label, odd, jobs[1].mode, jobs[1].start)
    assert batch_runs(jobs) is None


def test_the_serial_sweep_says_how_many_samples_were_batched(tmp_path, capsys):
    path = tmp_path / "lag_lead.json"
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", path)
    args = ["sweep", str(path), "--tolerance", TOLERANCES[0], "--tolerance", TOLERANCES[1], "--samples", "40"]
    assert main([*args, "--serial", "--json"]) == 0
    out = capsys.readouterr()
    summary = json.loads(out.out)
    assert "40 of 40 samples evaluated as a batch" in summary["settings"]["note"]
    assert "evaluated as a batch" in out.err


def test_two_flight_conditions_and_a_value_per_condition(tmp_path):
    """Every condition's loop is batched, a parameter with a value per condition draws one each."""
    model = json.loads((EXAMPLES / "coebra_lag_lead.json").read_text())
    second = copy.deepcopy(model["problem"]["conditions"][0])
    second["name"] = "heavy"
    second["plant"]["blocks"][1]["transfer"]["expression"] = "12000/(s*(s+6)*(s+25))"
    model["problem"]["conditions"].append(second)
    model["problem"]["parameters"][1]["value"] = [0.2, 0.25]  # T2, one per condition
    path = tmp_path / "two.json"
    path.write_text(json.dumps(model))
    jobs = _jobs(path, 40)
    batch = batch_runs(jobs)
    assert batch is not None and batch.per_loop == 0
    assert {m["condition"] for m in batch.runs[0]["measures"]} == {"nominal", "heavy"}
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


def test_without_a_cluster_asked_for_the_batch_runs_here(tmp_path):
    """No scheduler, cluster or workers named: the batch in this process, not a local cluster."""
    jobs = _jobs(_session(tmp_path), 30)
    outcome = execute(jobs)
    assert outcome.serial and outcome.note.startswith("30 of 30 samples evaluated as a batch")
    for got, job in zip(outcome.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))

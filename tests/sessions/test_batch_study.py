"""A tolerance study evaluated as a batch (issue 41, section 1): every sample's run is
the per-loop path's (`run_job`), its margins equal to 1e-12 relative, on the lag-lead and on
random loops, diagrams (an inner loop, parallel paths, the launch vehicle, blocks of several
ports: issue 53), loops in z and diagrams in z (an inner loop, parallel paths, a state-space
block in z); samples the batch cannot certify (an odd form, a certificate
that fails at a near-tangent crossover) go per loop, alone, and the study's note names them; a
study that is not batched (a delay, a tabulated plant, a loop in z's time or closed-loop peak
rows) is evaluated per loop on its problem built once, every run equal to `run_job`'s, and its
note says why; `sweep --serial` says what it did."""

from __future__ import annotations

import copy
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from sessions.examples.coebra_launch_vehicle import _block  # a diagram's expression block
from sessions.store import load_session
from sessions.sweeps.batch_study import batch_runs
from sessions.sweeps.jobs import execute, execute_serial, run_job
from sessions.sweeps.plan import plan
from tests.engine.loopfactory import random_cascade_structure
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


def _same_run(batch: dict, loop: dict, exact: bool = False, abscissa: float = 1e-9) -> None:
    """The batch's run is ``loop``'s, its numbers to 1e-12 relative (``exact``: equal), the
    stability abscissa to ``abscissa`` (the eigenvalues of other matrices, unless they are the same)."""
    assert set(batch) == set(loop) | {"attempts"}
    if exact:
        assert {k: v for k, v in batch.items() if k not in ("seconds", "attempts")} == {
            k: v for k, v in loop.items() if k != "seconds"
        }
        return
    for key in loop:
        if key not in ("seconds", "measures", "ranking"):
            assert batch[key] == loop[key], key
    assert batch["ranking"] == pytest.approx(loop["ranking"], rel=1e-12)
    for got, want in zip(batch["measures"], loop["measures"], strict=True):
        assert {k: v for k, v in got.items() if k not in ("value", "frequency")} == {
            k: v for k, v in want.items() if k not in ("value", "frequency")
        }
        exact = abscissa if got["kind"] == "stability_abscissa" else 1e-12
        floor = 0.0 if got["kind"] == "stability_abscissa" else 1e-12  # (relative only: an abscissa near 0)
        for key in ("value", "frequency"):
            if isinstance(want[key], float):
                assert got[key] == pytest.approx(want[key], rel=exact, abs=floor), (got["name"], key)
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
    jobs = list(_jobs(_session(tmp_path), 5))  # a list of jobs, one changed (the study's are made when read)
    odd = copy.deepcopy(jobs[2].model)
    odd["problem"]["parameters"][0]["value"] = 10.0
    jobs[2] = type(jobs[2])(2, jobs[2].label, odd, jobs[2].mode, {**jobs[2].start, "T1": 10.0})
    batch = batch_runs(jobs)
    assert batch is not None and (batch.per_loop, batch.searched) == (1, 0)
    assert "4 of 5 samples evaluated as a batch" in batch.note
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


def _per_loop_equal(jobs, why: str) -> None:
    """The study is not batched, its note says why, and every sample, evaluated per loop on the
    problem built once, is `run_job`'s run exactly."""
    batch = batch_runs(jobs)
    assert batch is not None and batch.per_loop == len(jobs) and batch.unbatched == why
    assert (
        batch.note == f"{len(jobs)} samples evaluated per loop on the study's problem, built once (not batched: {why})"
    )
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()), exact=True)
    assert batch_runs(jobs, unbatched=False) is None  # execute() leaves it to a local cluster


def _edited(tmp_path: Path, edit) -> Path:
    """The lag-lead example changed by ``edit`` (a function of its problem's plant)."""
    path = _session(tmp_path)
    model = json.loads(path.read_text())
    edit(model["problem"]["conditions"][0]["plant"])
    path.write_text(json.dumps(model))
    return path


def test_a_loop_with_a_delay_is_evaluated_per_loop(tmp_path):
    def delayed(plant: dict) -> None:
        plant["blocks"][1]["output"] = "yd"
        delay = {"input": "yd", "name": "delay", "output": "y", "transfer": {"kind": "delay", "tau": 0.002}}
        plant["blocks"].append(delay)

    jobs = _jobs(_edited(tmp_path, delayed), 6)
    _per_loop_equal(jobs, "a loop with a delay or a table")
    outcome = execute_serial(jobs)
    assert "not batched: a loop with a delay" in outcome.note
    assert [run["status"] for run in outcome.runs] == ["running"] * 6


def test_a_tabulated_plant_is_evaluated_per_loop(tmp_path):
    """The lag-lead's plant as a table of its frequency response (cartesian, 200 points)."""
    omega = np.logspace(-2, 3, 200)
    response = 16000 / (1j * omega * (1j * omega + 8) * (1j * omega + 20))

    def tabulated(plant: dict) -> None:
        table = {"form": "cartesian", "frequency": omega.tolist(), "first": response.real.tolist()}
        plant["blocks"][1]["transfer"] = {"kind": "table", "table": {**table, "second": response.imag.tolist()}}

    _per_loop_equal(_jobs(_edited(tmp_path, tabulated), 6), "a loop with a delay or a table")


def test_a_loop_that_is_not_one_cascade_is_batched_on_its_realizations(tmp_path):
    """The lag-lead's plant with a rate feedback around its lags (an inner loop): its minimal forms
    from the stacked realizations, searched as a batch (issue 53)."""

    def inner(plant: dict) -> None:
        plant["blocks"][1:] = [
            {
                "input": "u2",
                "name": "lags",
                "output": "v",
                "transfer": {"kind": "expression", "expression": "16000/((s+8)*(s+20))"},
            },
            {
                "input": "v",
                "name": "integrator",
                "output": "y",
                "transfer": {"kind": "expression", "expression": "1/s"},
            },
            {
                "input": "v",
                "name": "tachometer",
                "output": "w",
                "transfer": {"kind": "expression", "expression": "0.002"},
            },
        ]
        plant["junctions"].append({"name": "inner", "output": "u2", "plus": ["u"], "minus": ["w"]})

    batched, searched, done = _batched_equal(_jobs(_edited(tmp_path, inner), 6))
    assert batched + searched == done == 6  # (before: 0 of 6, its frequency rows per loop)


def _kuo_z(tmp_path: Path, plant: str | None = None, name: str = "z") -> Path:
    """Kuo's loop in z (T = 0.5 s), its plant replaced when given."""
    model = json.loads((EXAMPLES / "coebra_kuo_z.json").read_text())
    if plant is not None:
        model["problem"]["conditions"][0]["plant"]["blocks"][1]["transfer"]["expression"] = plant
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(model))
    return path


def test_a_loop_in_z_is_batched_and_equals_the_per_loop_path(tmp_path):
    """Issue 53, section 1: Kuo's loop in z went per loop (not batched: a loop in z); its w-plane
    form is batched now (the (1 - w) of each z = (1 + w)/(1 - w) cancelled as the per-loop path
    cancels it), every run `run_job`'s, frequencies in rad/s."""
    jobs = _jobs(_kuo_z(tmp_path), 60, ["T1=+-30%", "T2=+-30%"])
    batch = batch_runs(jobs)
    assert batch is not None and not batch.unbatched and batch.per_loop == 0
    assert batch.done - batch.searched >= 50
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


def test_random_loops_in_z_equal_the_per_loop_path(tmp_path):
    """Random plants in z (a gain, two real zeros inside or outside the unit circle, an
    integrator z - 1, a real pole and a complex pair inside it, one a light one) under Kuo's
    compensator, T1 and T2 +-50 %: every run is `run_job`'s."""
    batched = total = 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        a, b = rng.uniform(-1.5, 0.9, 2).round(6).tolist()
        p, r, theta = (float(rng.uniform(lo, hi)) for lo, hi in ((0.1, 0.95), (0.6, 0.995), (0.2, 2.5)))
        k = float(10 ** rng.uniform(-1.5, -0.5))
        plant = f"{k!r}*(z-({a!r}))*(z-({b!r}))/((z-1)*(z-{p!r})*(z**2-{2 * r * math.cos(theta)!r}*z+{r * r!r}))"
        jobs = _jobs(_kuo_z(tmp_path, plant, f"z{seed}"), 20, ["T1=+-50%", "T2=+-50%"])
        batch = batch_runs(jobs)
        assert batch is not None and not batch.unbatched
        for got, job in zip(batch.runs, jobs, strict=True):
            _same_run(got, run_job(job.payload()))
        batched += batch.done - batch.per_loop - batch.searched
        total += batch.done
    assert batched >= 0.7 * total


def test_random_loops_in_z_with_time_and_peak_rows_equal_the_per_loop_path(tmp_path):
    """Random plants in z (as above) with step rows, a ramp's peak response, Ms, Mt, disk and delay
    margin rows: 58 of 60 samples batched (0 before: time and peak rows of a loop in z went per
    loop), the rest by the per-loop search on their forms, every run `run_job`'s to 1e-12."""
    batched = total = 0
    kinds = ("sensitivity_peak", "complementary_sensitivity_peak", "disk_margin", "delay_margin")
    for seed in range(10, 14):
        rng = np.random.default_rng(seed)
        a, b = rng.uniform(-1.5, 0.9, 2).round(6).tolist()
        p, r, theta = (float(rng.uniform(lo, hi)) for lo, hi in ((0.1, 0.95), (0.6, 0.995), (0.2, 2.5)))
        k = float(10 ** rng.uniform(-1.5, -0.5))
        plant = f"{k!r}*(z-({a!r}))*(z-({b!r}))/((z-1)*(z-{p!r})*(z**2-{2 * r * math.cos(theta)!r}*z+{r * r!r}))"
        path = _with_time_rows(_kuo_z(tmp_path, plant, f"zt{seed}"))
        model = json.loads(path.read_text())
        model["problem"]["targets"] += [{"measure": kind, "bands": [{"desired": 1.0}]} for kind in kinds]
        path.write_text(json.dumps(model))
        together, _, done = _batched_equal(_jobs(path, 15, ["T1=+-50%", "T2=+-50%"]))
        batched, total = batched + together, total + done
    assert batched >= 0.9 * total


def test_the_launch_vehicle_is_batched_on_its_realizations_minimal_forms(tmp_path):
    """Issue 53: three conditions whose loops are not one cascade (parallel sensor paths, each
    bending mode held by three blocks): 0 of N samples were batched (their frequency rows went per
    loop: a 52-root form from QZ, with a zero at 3e12 rad/s, beyond the batched search).  Their
    minimal forms from the stacked realizations (`engine.loop.batch_realized_forms`) are searched
    as a batch and polished on the realizations; every run is `run_job`'s to 1e-12 and no sample
    goes the per-loop path."""
    shutil.copy(EXAMPLES / "coebra_launch_vehicle.json", tmp_path / "lv.json")
    jobs = _jobs(tmp_path / "lv.json", 12, ["WF=+-10%", "ZF=+-10%", "TA=+-10%"])
    batched, searched, done = _batched_equal(jobs)
    assert (batched + searched, done) == (12, 12)
    assert batched >= 4  # certified by the batch in every condition (the others: the search on their forms)


def test_a_sample_that_is_not_of_the_study_keeps_the_study_per_loop(tmp_path):
    jobs = list(_jobs(_session(tmp_path), 3))
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


def _loop_session(tmp_path: Path, blocks: list[str], values: dict[str, float], name: str = "loop") -> Path:
    """A unity-feedback session of a cascade of expression blocks (e -> ... -> y), the lag-lead's
    targets (crossover, gain and phase margins; slp adds the stability row) and parameters."""
    model = json.loads((EXAMPLES / "coebra_lag_lead.json").read_text())
    plant = model["problem"]["conditions"][0]["plant"]
    signals = ["e", *(f"x{k}" for k in range(1, len(blocks))), "y"]
    plant["blocks"] = [
        {"input": a, "name": f"block {k}", "output": b, "transfer": {"kind": "expression", "expression": text}}
        for k, (a, b, text) in enumerate(zip(signals, signals[1:], blocks))
    ]
    model["problem"]["parameters"] = [{"name": n, "value": v, "min": 1e-9, "max": 1e9} for n, v in values.items()]
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(model))
    return path


def test_random_loops_equal_the_per_loop_path(tmp_path):
    """Six random cascades (`tests.engine.test_batch_margins`: gains, real zeros and poles,
    light pairs, integrators), every parameter +-20 %, 25 samples each: every run is
    `run_job`'s; most samples batched, the rest named in the note."""

    batched = 0
    for seed in range(6):
        blocks, values = random_cascade_structure(np.random.default_rng(seed))
        path = _loop_session(tmp_path, blocks, values, f"random{seed}")
        jobs = _jobs(path, 25, [f"{name}=+-20%" for name in values])
        batch = batch_runs(jobs)
        assert batch is not None and not batch.unbatched
        for got, job in zip(batch.runs, jobs, strict=True):
            _same_run(got, run_job(job.payload()))
        for sample in (*batch.alone, *batch.by_search)[:10]:
            assert str(sample) in batch.note
        batched += batch.done - batch.per_loop - batch.searched
    assert batched >= 0.7 * 6 * 25


def test_samples_whose_certificate_fails_go_per_loop_alone_named_in_the_note(tmp_path):
    """K/s times a light resonance: |GH|'s local peak at the resonance is 1 within rounding in
    sample 3 (1e-14 above) and nearly in sample 7 (1e-8 above), where two crossovers nearly meet,
    which the batch's certificate does not settle: those two alone go per loop (or to the
    per-loop search on their batched forms), the note names them, every run is `run_job`'s."""
    from scipy.optimize import minimize_scalar

    expression = "K*25/(s*(s**2 + 0.5*s + 25))"
    magnitude = lambda w: abs(25 / (1j * w * ((1j * w) ** 2 + 0.5j * w + 25)))  # noqa: E731
    peak = magnitude(
        minimize_scalar(lambda w: -magnitude(w), bounds=(3, 6), method="bounded", options={"xatol": 1e-12}).x
    )
    path = _loop_session(tmp_path, [expression], {"K": 0.6 / peak})
    jobs = list(_jobs(path, 10, ["K=+-10%"]))
    for k, tangent in ((3, (1 + 1e-14) / peak), (7, (1 + 1e-8) / peak)):
        odd = copy.deepcopy(jobs[k].model)
        odd["problem"]["parameters"][0]["value"] = tangent
        jobs[k] = type(jobs[k])(k, jobs[k].label, odd, jobs[k].mode, {"K": tangent})
    batch = batch_runs(jobs)
    assert batch is not None and not batch.unbatched
    assert set(batch.alone) | set(batch.by_search) == {3, 7}
    assert batch.note.startswith("8 of 10 samples evaluated as a batch")
    for what, samples in (("batched forms", batch.by_search), ("certificate failed)", batch.alone)):
        if samples:
            listed = ", ".join(str(k) for k in samples)
            assert f"{what} (sample{'s' if len(samples) > 1 else ''} {listed})" in batch.note
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


def test_a_value_against_its_parameters_sign_goes_to_its_own_session(tmp_path):
    """T2 is positive; normal:80 % draws some negative values, which a sample's own session
    evaluates at the sign's bound (slp clips its start to it): those samples go that way, alone."""
    path = _session(tmp_path)
    model = json.loads(path.read_text())
    model["problem"]["parameters"][1]["sign"] = "positive"
    path.write_text(json.dumps(model))
    jobs = _jobs(path, 30, ["T1=+-10%", "T2=normal:80%"])
    negative = [job.index for job in jobs if job.start["T2"] < 0]
    assert negative
    batch = batch_runs(jobs)
    assert batch is not None and set(negative) <= set(batch.alone)
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()), exact=job.index in negative)


@pytest.mark.parametrize("every_run", [True, False])
def test_runs_held_as_arrays_tally_as_run_by_run(tmp_path, every_run):
    """Issue 53: a study's batched samples reach its Tally as arrays (`Tally.add_records`), a
    run made only when kept; the rows, worst samples, distributions and kept runs are those of
    the same runs added one by one (a light-mode plant: some samples by the per-loop search,
    interleaved)."""
    from sessions.sweeps.dispersion import Tally
    from tests.engine.test_batch_margins import _light_mode_plant

    blocks, values = _light_mode_plant(np.random.default_rng(6))
    jobs = _jobs(_loop_session(tmp_path, blocks, values), 120, [f"{name}=+-30%" for name in values])
    arrays, one_by_one = Tally(every_run), Tally(every_run)
    batch = batch_runs(jobs, tally=arrays)
    assert batch is not None and batch.done == 120 and batch.runs == []
    for run in batch_runs(jobs).runs:
        one_by_one.add(run)
    assert arrays.worst_case() == one_by_one.worst_case()
    assert json.dumps(arrays.rows()) == json.dumps(one_by_one.rows())
    strip = lambda runs: [{k: v for k, v in run.items() if k != "seconds"} for run in runs]  # noqa: E731
    assert strip(arrays.runs()) == strip(one_by_one.runs())
    assert len(arrays.runs()) == (120 if every_run else len({row["worst_sample"] for row in arrays.worst_case()}))


def test_the_worst_of_a_stretch_follows_the_run_by_run_rule():
    """`_worst_of` against `Tally.add`'s rule taken value by value: NaN worsts replaced by any
    value, values by strictly worse ones, the first of equals kept (random values with NaN, inf
    and ties)."""
    from sessions.sweeps.dispersion import _worst_of

    rng = np.random.default_rng(2)
    pool = np.array([np.nan, np.inf, -np.inf, 0.0, 1.0, 1.0, 2.5, -3.0])
    for _ in range(400):
        values = rng.choice(pool, int(rng.integers(0, 6)))
        start, at_least = float(rng.choice(pool)), bool(rng.integers(0, 2))
        worst, expected = start, None
        for j, value in enumerate(values):
            if worst != worst or (value < worst if at_least else value > worst):
                worst, expected = value, j
        assert _worst_of(start, values, at_least) == expected, (start, values.tolist(), at_least)


def test_the_constrained_lead_of_loopcraft_new_is_batched(tmp_path):
    """Issue 53's constrained lead: `loopcraft new`'s lead (T1 <= 20*T2, T2 <= 20*T1) at T1 = 2,
    T2 = 0.1, where T1 <= 20*T2 binds; its study's samples (the constraints left out of the
    study's document, 98f0f04) are all batched and every run is `run_job`'s."""
    from sessions.new.templates import new_session

    model = new_session("10/(s*(s+1)*(s+5))", "lead")
    for entry in model["problem"]["parameters"]:
        entry["value"] = {"K": 1.0, "T1": 2.0, "T2": 0.1}[entry["name"]]
    path = tmp_path / "lead.json"
    path.write_text(json.dumps(model))
    jobs = plan(load_session(path), "tolerance", ["K=+-10%", "T1=+-10%", "T2=+-10%"], None, 7, 60, "lhs")[0]
    batch = batch_runs(jobs)
    assert batch is not None and batch.per_loop == 0 and batch.done - batch.searched >= 55
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


@pytest.mark.parametrize("samples", [40, 10_050])
def test_save_samples_writes_every_samples_values(tmp_path, capsys, samples):
    """Issue 53, section 3: --save-samples FILE.npz holds every sample's drawn values and row
    values; they are the runs' own (every run kept at 40 samples; at 10 050 the runs kept are
    checked, and every row's values against the summary's percentiles)."""
    from sessions.sweeps.dispersion import percentiles

    path = tmp_path / "lag_lead.json"
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", path)
    out = tmp_path / "samples.npz"
    args = ["sweep", str(path), "--tolerance", TOLERANCES[0], "--tolerance", TOLERANCES[1]]
    assert main([*args, "--samples", str(samples), "--serial", "--json", "--save-samples", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    saved = np.load(out)
    assert saved["index"].tolist() == list(range(samples))
    assert saved["parameter/T1"].shape == (samples,)
    runs = summary["runs"]
    assert len(runs) == (samples if samples <= 10_000 else len(runs))
    for run in runs:
        k = run["index"]
        assert run["start"] == {"T1": saved["parameter/T1"][k], "T2": saved["parameter/T2"][k]}
        for m in run["measures"]:
            assert float(m["value"]) == pytest.approx(saved[f"row/{m['name']}@{m['condition']}"][k], rel=0, nan_ok=True)
    assert len(summary["worst_case"]) == 4
    for row in summary["worst_case"]:
        values = saved[f"row/{row['name']}@{row['condition']}"]
        assert list(row["percentiles"].values()) == percentiles(values[~np.isnan(values)])


def test_save_samples_is_for_a_tolerance_study(tmp_path, capsys):
    path = tmp_path / "lag_lead.json"
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", path)
    assert main(["sweep", str(path), "--starts", "2", "--serial", "--save-samples", str(tmp_path / "x.npz")]) == 2
    assert "--save-samples is for a tolerance study" in capsys.readouterr().err


@pytest.mark.parametrize(
    "plant",
    [
        "0.2*(z+0.5)/((z-1)*(z-0.6))*z**-1",
        "0.1*(z+0.9)*(z-0.3)/(z**2*(z-1)*(z-0.8))",
        "0.05/((z-1)**2)*(z-0.95)",
        "0.3*(z**2-1.2*z+0.5)/((z-1)*(z**2-1.6*z+0.8)*(z-0.2))",
        "0.1*(z+1)/((z-1)*(z-0.5))",
    ],
    ids=["delay", "poles-at-0", "double-integrator", "pairs", "zero-at-minus-1"],
)
def test_loops_in_z_of_other_shapes_are_batched(tmp_path, plant):
    """A sample delay (z**-1), poles at z = 0, a double integrator, complex pairs typed as
    quadratics in z, and a zero at z = -1 (z + 1 is 2/(1 - w): its sum's leading coefficient
    vanishes in every sample, which the batch form drops; the crash it was: an infinite root)."""
    jobs = _jobs(_kuo_z(tmp_path, plant), 8, ["T1=+-30%", "T2=+-30%"])
    batch = batch_runs(jobs)
    assert batch is not None and not batch.unbatched and batch.per_loop == 0
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


def _with_modal_peaks(path: Path) -> Path:
    """The session with modal-peak rows (|GH|'s maxima in dB and their phase) over two bands."""
    model = json.loads(path.read_text())
    bands = [
        {"low": 0.1, "high": 10.0, "desired": -10.0, "required": -6.0},
        {"low": 10.0, "high": 1e4, "desired": -12.0},
    ]
    model["problem"]["targets"] += [
        {"measure": "modal_peak_db", "bands": bands},
        {"measure": "modal_peak_phase_deg", "bands": [{"low": 0.1, "high": 1e4, "desired": 90.0}]},
    ]
    path.write_text(json.dumps(model))
    return path


def test_modal_peak_rows_of_cascades_are_batched(tmp_path):
    """Issue 53, section 1: a cascade with modal-peak rows went per loop (not batched: rows of
    kind modal_peak_db); the maxima of |GH| the batched search polishes and certifies are its
    attenuation margins now.  Random cascades with light pairs, every run `run_job`'s, most
    samples batched."""

    batched = total = peaks = 0
    for seed in (1, 2, 4, 6, 9):
        blocks, values = random_cascade_structure(np.random.default_rng(seed))
        path = _with_modal_peaks(_loop_session(tmp_path, blocks, values, f"peaks{seed}"))
        jobs = _jobs(path, 20, [f"{name}=+-20%" for name in values])
        batch = batch_runs(jobs)
        assert batch is not None and batch.unbatched == ""
        for got, job in zip(batch.runs, jobs, strict=True):
            want = run_job(job.payload())
            _same_run(got, want)
            peaks += sum(m["kind"] == "modal_peak_db" and isinstance(m["frequency"], float) for m in want["measures"])
        batched += batch.done - batch.per_loop - batch.searched
        total += batch.done
    assert peaks >= 60  # rows that found a peak (80 of them), not only absent ones
    assert batched >= 0.7 * total


def _batched_equal(jobs, abscissa: float = 1e-9) -> tuple[int, int, int]:
    """The study evaluated as a batch, every run `run_job`'s (the stability abscissa to ``abscissa``):
    (samples batched, samples by the per-loop search on their batched forms, samples)."""
    batch = batch_runs(jobs)
    assert batch is not None and batch.unbatched == ""
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()), abscissa=abscissa)
    return batch.done - batch.per_loop - batch.searched, batch.searched, batch.done


def _with_time_rows(path: Path) -> Path:
    """The session with step rows on r -> y (overshoot, rise, settling, peak time, steady-state
    error, over 3 s at 151 points) and a peak response to a ramp up and down."""
    model = json.loads(path.read_text())
    step = {"input": "r", "output": "y", "horizon": 3.0, "points": 151, "profile": [{"time": 0.0, "step": 1.0}]}
    ramp = {**step, "profile": [{"time": 0.0, "slope": 1.0}, {"time": 0.5, "slope": -2.0}, {"time": 1.0, "slope": 1.0}]}
    kinds = ("overshoot_percent", "rise_time", "settling_time", "peak_time", "steady_state_error")
    model["problem"]["targets"] += [
        {"measure": kind, "bands": [{"desired": 1.0}], "requirement": False, "response": step} for kind in kinds
    ] + [{"measure": "peak_response", "bands": [{"desired": 0.0}], "requirement": False, "response": ramp}]
    path.write_text(json.dumps(model))
    return path


def test_time_rows_of_cascades_are_batched(tmp_path):
    """Issue 53, section 1: a cascade with step and peak-response rows went per loop (not
    batched: rows of kind overshoot_percent, ...); each sample's closed loop, realized as the
    per-loop path realizes it, is simulated with the others in one recursion now.  The lag-lead
    and random cascades: every run `run_job`'s (rows to 1e-12 relative), most samples batched."""

    batched = total = 0
    studies = [(_with_time_rows(_session(tmp_path)), TOLERANCES)]
    for seed in (2, 4, 9):
        blocks, values = random_cascade_structure(np.random.default_rng(seed))
        path = _with_time_rows(_loop_session(tmp_path, blocks, values, f"timed{seed}"))
        studies.append((path, [f"{name}=+-20%" for name in values]))
    for path, tolerances in studies:
        found, _, done = _batched_equal(_jobs(path, 15, tolerances))
        batched, total = batched + found, total + done
    assert batched >= 0.7 * total


def test_closed_loop_peak_rows_of_cascades_are_batched(tmp_path):
    """Issue 53, section 1: a cascade with Ms, Mt, disk-margin and delay-margin rows had each
    sample's peaks found by the per-loop grid-free peak search on its batched form (every sample
    "by the per-loop search"); they are found for every sample at once now
    (`engine.margins.pole_zero.batch_peaks`, the delay margins from the phase margins' arrays), a
    sample the batched search does not certify by the per-loop search, named in the note.  The
    lag-lead and random cascades, every run `run_job`'s (59 of 60 samples batched, 0 before)."""

    studies = [(_session(tmp_path), TOLERANCES)]
    for seed in (2, 6, 9):
        blocks, values = random_cascade_structure(np.random.default_rng(seed))
        studies.append((_loop_session(tmp_path, blocks, values, f"closed{seed}"), [f"{n}=+-20%" for n in values]))
    kinds = ("sensitivity_peak", "complementary_sensitivity_peak", "disk_margin", "delay_margin")
    batched = total = 0
    for path, tolerances in studies:
        model = json.loads(path.read_text())
        model["problem"]["targets"] += [{"measure": kind, "bands": [{"desired": 1.0}]} for kind in kinds]
        model["problem"]["targets"].append(
            {"measure": "sensitivity_peak", "bands": [{"low": 0.5, "high": 5.0, "desired": 1.5}]}
        )
        path.write_text(json.dumps(model))
        together, _, done = _batched_equal(_jobs(path, 15, tolerances))
        batched, total = batched + together, total + done
    assert batched >= 0.95 * total


def test_time_rows_of_a_loop_in_z_are_batched_and_stepped_in_z(tmp_path):
    """Issue 53, section 1: Kuo's loop in z with step rows and a peak response to a ramp went per loop
    (not batched: time rows of a loop in z); every sample's closed loop is stepped in z with the
    others in one recursion now (`engine.closed_loop.batch_time.batch_simulate_sampled`), every run
    `run_job`'s.  The per-loop path stepped its realization in w as if it were continuous (its sample
    time was lost when the loop was closed); the peak response to a unit step equals
    python-control's discrete closed loop's at the samples."""
    control = pytest.importorskip("control")
    path = _with_time_rows(_kuo_z(tmp_path))
    model = json.loads(path.read_text())
    step = {"input": "r", "output": "y", "horizon": 10.0, "points": 11, "profile": [{"time": 0.0, "step": 1.0}]}
    for target in model["problem"]["targets"]:
        if target.get("response"):
            target["response"]["horizon"] = 10.0
    model["problem"]["targets"].append(
        {"measure": "peak_response", "bands": [{"desired": 0.0}], "requirement": False, "response": step}
    )
    path.write_text(json.dumps(model))
    jobs = _jobs(path, 20, ["T1=+-30%", "T2=+-30%"])
    batched, _, done = _batched_equal(jobs)
    assert batched == done
    z = control.tf("z")
    for run in batch_runs(jobs).runs:
        t1, t2 = run["start"]["T1"], run["start"]["T2"]
        loop = ((1 + t1) * z - (t1 - 1)) / ((1 + t2) * z - (t2 - 1)) * 0.39 * (z + 1.31) * (z + 0.054)
        loop = control.tf(loop.num, loop.den, 0.5) / control.tf([1, -1.368, 0.368, 0], [1], 0.5)
        closed = control.feedback(loop, 1)
        _, y = control.step_response(closed, T=np.arange(21) * 0.5)
        stable = bool(np.all(np.abs(closed.poles()) < 1))
        peak = [m["value"] for m in run["measures"] if m["kind"] == "peak_response"][-1]
        assert peak == (pytest.approx(float(np.max(np.abs(y))), rel=1e-12) if stable else "nan")


@pytest.mark.parametrize("plant", [None, "0.02*(z+1)/((z-1)*(z**2-1.6012*z+0.9409))"])
def test_closed_loop_peak_rows_of_a_loop_in_z_are_batched(tmp_path, plant):
    """Issue 53, section 1: Kuo's loop in z with Ms, Mt, disk and delay margin rows (over the whole
    axis, and Ms over 0.5-3 rad/s) went per loop (not batched: closed-loop peak rows of a loop in
    z); its samples' peaks are found at once on their w-plane forms now (bands in nu = tan(omega
    T/2), frequencies back in rad/s), every run `run_job`'s.  Kuo's plant and one with a lightly
    damped pair (poles at 0.97 exp(+-0.6j)): 60 of 60 samples batched."""
    path = _kuo_z(tmp_path, plant)
    model = json.loads(path.read_text())
    kinds = ("sensitivity_peak", "complementary_sensitivity_peak", "disk_margin", "delay_margin")
    model["problem"]["targets"] += [{"measure": kind, "bands": [{"desired": 1.0}]} for kind in kinds]
    band = {"low": 0.5, "high": 3.0, "desired": 1.5}
    model["problem"]["targets"].append({"measure": "sensitivity_peak", "bands": [band]})
    path.write_text(json.dumps(model))
    batched, _, done = _batched_equal(_jobs(path, 30, ["T1=+-30%", "T2=+-30%"]))
    assert batched >= 0.9 * done


def test_a_certified_sample_makes_no_margin_object(tmp_path, monkeypatch):
    """Issue 53 (the run record built from arrays): a certified sample's gain and phase margins
    stay in the batch's arrays (`engine.margins.batch.BatchLoops`) and its rows are read from
    them; a `Margin` per margin per sample was made before (80 for these 40 samples)."""
    from engine.margins import values

    made = []
    plain = values.Margin.__init__
    monkeypatch.setattr(values.Margin, "__init__", lambda self, *a, **k: made.append(1) or plain(self, *a, **k))
    jobs = _jobs(_session(tmp_path), 40)
    batch = batch_runs(jobs)
    monkeypatch.undo()
    assert batch is not None and batch.per_loop == 0 and batch.searched == 0
    assert made == []
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))


def test_modal_peak_rows_of_a_loop_in_z_equal_the_per_loop_path(tmp_path):
    """The attenuation margins of a loop in z read from the batch's arrays (frequencies turned to
    rad/s there) equal the per-loop path's: Kuo's loop with a lightly damped pair in its plant
    (poles at 0.97 exp(+-0.6j), a peak near 1.2 rad/s)."""
    plant = "0.02*(z+1)/((z-1)*(z**2-1.6012*z+0.9409))"
    jobs = _jobs(_with_modal_peaks(_kuo_z(tmp_path, plant)), 30, ["T1=+-30%", "T2=+-30%"])
    batch = batch_runs(jobs)
    assert batch is not None and not batch.unbatched and batch.per_loop == 0
    for got, job in zip(batch.runs, jobs, strict=True):
        want = run_job(job.payload())
        _same_run(got, want)
    found = [m for m in want["measures"] if m["kind"] == "modal_peak_db" and isinstance(m["frequency"], float)]
    assert found


def test_rows_at_another_break_of_a_diagram_read_the_loop_there(tmp_path):
    """The two-path autopilot (`tests.sessions.test_two_path_breaks`) with rows at u_att as well as
    at its loop's break: each (condition, break) gets its own batched forms, every run is
    `run_job`'s (0 of 6 batched before; reading every row at the condition's break put PM1@u_att
    at dc's phase margin, 12.4 deg for 13.1)."""
    from tests.sessions.test_two_path_breaks import document

    path = tmp_path / "two_paths.json"
    path.write_text(json.dumps({**document(), "algorithm": {"name": "slp", "settings": {}}}))
    batched, searched, done = _batched_equal(_jobs(path, 6, ["KA=+-10%"]))
    assert batched + searched == done == 6


def _airframe_block(a, b, c, d=None) -> dict:
    """A block of two ports (inputs u and v, outputs y and y2) of the given matrices."""
    transfer = {"kind": "state_space", "A": a, "B": b, "C": c, "D": d}
    return {"name": "airframe", "inputs": ["u", "v"], "outputs": ["y", "y2"], "transfer": transfer}


def test_a_diagram_with_a_block_of_several_ports_is_batched(tmp_path):
    """The two-path autopilot with its body and attitude as one block of two ports (the fin
    deflection and the disturbance moment in, the rate and the attitude out): 0 of 6 samples were
    batched (its loops had no batch form: a block of several ports had no batched realization);
    now every sample is, every run `run_job`'s to 1e-12."""
    from tests.sessions.test_two_path_breaks import document

    model = {**document(), "algorithm": {"name": "slp", "settings": {}}}
    plant = model["problem"]["conditions"][0]["plant"]
    block = _airframe_block([[-0.5, 0.0], [1.0, 0.0]], [[4.0, 4.0], [0.0, 0.0]], [[1.0, 0.0], [0.0, 1.0]])
    block.update(inputs=["delta", "d"], outputs=["q", "theta"])
    plant["blocks"] = [b for b in plant["blocks"] if b["name"] not in ("body", "attitude")] + [block]
    plant["junctions"] = [j for j in plant["junctions"] if j["name"] != "moment"]
    path = tmp_path / "ported.json"
    path.write_text(json.dumps(model))
    batched, searched, done = _batched_equal(_jobs(path, 6, ["KA=+-10%", "KR=+-10%"]))
    assert (batched + searched, done) == (6, 6)


def _random_ported_session(rng: np.random.Generator, path: Path) -> list[str]:
    """A random loop around a block of two ports (random stable A, B, C, D: its modes real poles and
    light or damped pairs, in random coordinates): a lead u = K (1 + T1 s)/(1 + T2 s) e, two
    parallel sensor paths from its outputs (K1 y and K2 y2/(1 + T3 s), summed and fed back: e = r
    - K1 y - K2 y2/(1 + T3 s)), an inner loop from its second output into its second input (v = d - KI y2);
    broken at u.  Returns the tolerances of its parameters."""
    modes = [[-rng.uniform(0.5, 5.0)]]
    for _ in range(rng.integers(1, 3)):
        wn, zeta = rng.uniform(1.0, 20.0), 10 ** rng.uniform(-2, -0.2)
        modes.append([[-zeta * wn, wn * np.sqrt(1 - zeta**2)], [-wn * np.sqrt(1 - zeta**2), -zeta * wn]])
    n = sum(len(m) for m in modes)
    modal, at = np.zeros((n, n)), 0
    for m in modes:
        modal[at : at + len(m), at : at + len(m)] = m
        at += len(m)
    t = np.eye(n) + 0.3 * rng.standard_normal((n, n))
    a = t @ modal @ np.linalg.inv(t)
    b, c = rng.standard_normal((n, 2)), rng.standard_normal((2, n))
    d = (0.1 * rng.standard_normal((2, 2))).tolist() if rng.random() < 0.5 else None
    blocks = [
        _airframe_block(a.tolist(), b.tolist(), c.tolist(), d),
        _block("lead", "e", "u", "K*(1+T1*s)/(1+T2*s)"),
        _block("sensor 1", "y", "m1", "K1"),
        _block("sensor 2", "y2", "m2", "K2/(1+T3*s)"),
        _block("inner", "y2", "w", "KI"),
    ]
    junctions = [
        {"name": "error", "output": "e", "plus": ["r"], "minus": ["m1", "m2"]},
        {"name": "moment", "output": "v", "plus": ["d"], "minus": ["w"]},
    ]
    values = {
        "K": 10 ** rng.uniform(-0.5, 1.0),
        "T1": rng.uniform(0.2, 1.0),
        "T2": rng.uniform(0.01, 0.1),
        "K1": rng.uniform(0.5, 2.0),
        "K2": rng.uniform(0.1, 1.0),
        "T3": rng.uniform(0.01, 0.2),
        "KI": rng.uniform(0.1, 1.0),
    }
    model = json.loads((EXAMPLES / "coebra_lag_lead.json").read_text())
    condition = model["problem"]["conditions"][0]
    condition["break_at"] = "u"
    condition["plant"] = {"format": "diagram", "inputs": ["r", "d"], "blocks": blocks, "junctions": junctions}
    model["problem"]["parameters"] = [{"name": k, "value": v, "min": 1e-9, "max": 1e9} for k, v in values.items()]
    path.write_text(json.dumps(model))
    drawn = rng.choice(sorted(values), size=4, replace=False)
    return [f"{name}=+-20%" for name in drawn]


def test_random_diagrams_with_a_block_of_several_ports_equal_the_per_loop_path(tmp_path):
    """Issue 53: random multi-path loops around a random block of two ports
    (`_random_ported_session`; two of them with time rows on r -> y and modal peaks), four of
    their parameters drawn +-20 %: each study is batched
    (before: none was, its loop had no batch form) and every run is `run_job`'s, its rows to
    1e-12 relative; most samples certified by the batch."""
    batched = total = 0
    for seed in range(4):
        rng = np.random.default_rng(seed)
        path = tmp_path / f"ported{seed}.json"
        tolerances = _random_ported_session(rng, path)
        if seed % 2:
            _with_modal_peaks(_with_time_rows(path))
        done_batched, searched, done = _batched_equal(_jobs(path, 10, tolerances))
        batched += done_batched + searched
        total += done
    assert batched >= 0.7 * total


def _z_diagram(path: Path, plant: list[dict], junctions: list[dict], values: dict[str, float]) -> Path:
    """Kuo's loop in z (T = 0.5 s, its compensator e -> u in T1 and T2, broken at e, its targets) with
    the plant and sensors of ``plant`` and ``junctions`` (the error junction among them) and the
    parameters ``values``."""
    model = json.loads((EXAMPLES / "coebra_kuo_z.json").read_text())
    diagram = model["problem"]["conditions"][0]["plant"]
    diagram["blocks"][1:] = plant
    diagram["junctions"] = junctions
    model["problem"]["parameters"] = [{"name": k, "value": v, "min": 1e-9, "max": 1e9} for k, v in values.items()]
    path.write_text(json.dumps(model))
    return path


def test_a_diagram_in_z_is_batched_on_its_realizations(tmp_path):
    """Issue 53: Kuo's loop in z with a rate feedback around its plant's lags (an inner loop) and
    two parallel sensor paths went per loop, 0 of 12 samples batched (its loop had no batch form:
    a loop in z that is not one cascade); its w-plane form's realizations are made for every
    sample at once now and their minimal forms searched as a batch: 12 of 12, every run
    `run_job`'s to 1e-12."""
    plant = [
        _block("lags", "u2", "v", "0.13*3*(z+1.31)*(z+0.054)/(z*(z-0.368))"),
        _block("integrator", "v", "y", "1/(z-1)"),
        _block("tachometer", "v", "w", "Kt*z/(z-0.2)"),
        _block("sensor 1", "y", "m1", "0.7"),
        _block("sensor 2", "y", "m2", "K2*0.6/(z-0.4)"),
    ]
    junctions = [
        {"name": "error", "output": "e", "plus": ["r"], "minus": ["m1", "m2"]},
        {"name": "inner", "output": "u2", "plus": ["u"], "minus": ["w"]},
    ]
    path = _z_diagram(tmp_path / "zdiagram.json", plant, junctions, {"T1": 20.0, "T2": 20.0, "Kt": 0.05, "K2": 0.3})
    jobs = _jobs(path, 12, ["T1=+-30%", "T2=+-30%", "Kt=+-30%", "K2=+-30%"])
    batched, searched, done = _batched_equal(jobs, abscissa=1e-12)  # the closed realizations' eigenvalues
    assert (batched + searched, done) == (12, 12)
    assert batched >= 8


def _random_z_diagram(rng: np.random.Generator, path: Path, ported: bool = False) -> list[str]:
    """A random diagram in z: Kuo's compensator, a plant that is a random stable state-space block
    in z (a real pole and a light or damped pair inside the unit circle, in random coordinates)
    followed by an integrator 0.5/(z - 1), a rate feedback Kt (z - 1)/(z - q) from the block's
    output into its input (an inner loop), two parallel sensor paths K1 and K2 (1 - p)/(z - p)
    summed into the error; ``ported``: the block has two ports (r its second input, the rate
    feedback from its second output).  Returns the tolerances of four of its parameters."""
    pole, radius, angle = rng.uniform(0.2, 0.9), rng.uniform(0.6, 0.98), rng.uniform(0.2, 2.0)
    modal = np.zeros((3, 3))
    modal[0, 0] = pole
    modal[1:, 1:] = radius * np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
    t = np.eye(3) + 0.3 * rng.standard_normal((3, 3))
    a = t @ modal @ np.linalg.inv(t)
    b, c = rng.standard_normal(3), rng.standard_normal(3)
    dc = c @ np.linalg.solve(np.eye(3) - a, b)
    c *= rng.uniform(0.3, 1.0) / dc  # a DC gain of 0.3 to 1
    block = {"kind": "state_space", "A": a.tolist(), "B": b.tolist(), "C": c.tolist(), "D": 0.0}
    wired = {"input": "u2", "output": "v"}
    if ported:
        b2, c2 = np.stack([b, rng.standard_normal(3)], axis=1), np.stack([c, 0.3 * rng.standard_normal(3)])
        block = {"kind": "state_space", "A": a.tolist(), "B": b2.tolist(), "C": c2.tolist(), "D": None}
        wired = {"inputs": ["u2", "r"], "outputs": ["v", "v2"]}
    plant = [
        {"name": "plant", **wired, "transfer": block},
        _block("integrator", "v", "y", "0.5/(z-1)"),
        _block("tachometer", "v2" if ported else "v", "w", f"Kt*(z-1)/(z-{rng.uniform(0.1, 0.6)!r})"),
        _block("sensor 1", "y", "m1", "K1"),
        _block("sensor 2", "y", "m2", f"K2*{1 - (p := rng.uniform(0.2, 0.8))!r}/(z-{p!r})"),
    ]
    junctions = [
        {"name": "error", "output": "e", "plus": ["r"], "minus": ["m1", "m2"]},
        {"name": "inner", "output": "u2", "plus": ["u"], "minus": ["w"]},
    ]
    values = {
        "T1": rng.uniform(2.0, 10.0),
        "T2": rng.uniform(5.0, 20.0),
        "Kt": rng.uniform(0.05, 0.5),
        "K1": rng.uniform(0.2, 0.8),
        "K2": rng.uniform(0.1, 0.5),
    }
    _z_diagram(path, plant, junctions, values)
    return [f"{name}=+-20%" for name in rng.choice(sorted(values), size=4, replace=False)]


def test_random_diagrams_in_z_equal_the_per_loop_path(tmp_path):
    """Issue 53: random diagrams in z (`_random_z_diagram`: a state-space block in z, of two ports
    in every other one, an inner loop, parallel sensor paths; two with modal-peak rows, their
    maxima polished in w), four parameters drawn +-20 %: each study is batched (before: none was,
    a loop in z that is not one cascade had no batch form) and every run is `run_job`'s, its rows
    to 1e-12 relative; most samples certified by the batch."""
    batched = total = 0
    for seed in range(6):
        rng = np.random.default_rng(seed)
        path = tmp_path / f"zdiagram{seed}.json"
        tolerances = _random_z_diagram(rng, path, ported=seed % 2 == 1)
        if seed % 3 == 2:
            _with_modal_peaks(path)
        done_batched, searched, done = _batched_equal(_jobs(path, 20, tolerances), abscissa=1e-12)
        assert done_batched + searched == done
        batched += done_batched
        total += done
    assert batched >= 0.7 * total
    found = [m for m in run_job(_jobs(path, 1, tolerances)[0].payload())["measures"] if m["kind"] == "modal_peak_db"]
    assert any(isinstance(m["frequency"], float) for m in found)  # a peak found, not only absent ones


@pytest.mark.parametrize("in_z", [False, True])
def test_time_rows_simulate_a_bounded_group_of_samples_at_once(tmp_path, monkeypatch, in_z):
    """A batch's time rows hold at most `RESPONSE_FLOATS` response samples at once: a loop in z's
    horizon of 10 s at T = 1 ms is 10 001 samples a response, and the whole chunk's (5000
    samples) was 0.4 GB a row.  With the bound set below one response here, each simulation is
    given one sample, and every run is the one made with no bound."""
    from engine.slp import batch_rows

    path = _with_time_rows(_kuo_z(tmp_path) if in_z else _session(tmp_path))
    jobs = _jobs(path, 12, ["T1=+-30%", "T2=+-30%"])
    whole = batch_runs(jobs).runs
    sizes: list[int] = []
    for name in ("batch_simulate", "batch_simulate_sampled"):
        simulate = getattr(batch_rows, name)
        monkeypatch.setattr(batch_rows, name, lambda A, *rest, _f=simulate: sizes.append(len(A)) or _f(A, *rest))
    monkeypatch.setattr(batch_rows, "RESPONSE_FLOATS", 1)  # less than one response: one sample at a time
    grouped = batch_runs(jobs).runs
    assert sizes and max(sizes) == 1 and sum(sizes) >= 12, sizes
    for got, want in zip(grouped, whole, strict=True):
        assert {k: v for k, v in got.items() if k != "seconds"} == {k: v for k, v in want.items() if k != "seconds"}

"""What a tolerance study shows (issue 41, section 2): per measure and flight
condition the histogram, the percentiles, the fraction unmet with its 95 %
Clopper-Pearson interval and the worst sample with its values, checked against
numpy and scipy on the same samples; samples uniform or normal per parameter,
drawn at random or by Latin hypercube, replayed exactly from their seed; the worst
sample adopted by --adopt-worst; bad laws refused in one line, exit status 2."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binomtest, norm

from sessions.errors import SessionError
from sessions.store import load_session
from sessions.sweeps.dispersion import (
    PERCENTILE_KEYS,
    PERCENTILES,
    clopper_pearson,
    histogram,
    percentiles,
    shortfall,
    worst_row,
)
from sessions.sweeps.plan import parse_sweep, plan, tolerance_jobs
from sessions.sweeps.sampling import parse_tolerance
from tui.cli import main
from tui.cli.sweep import sweep_text

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _copy(tmp_path: Path, name: str) -> Path:
    shutil.copy(EXAMPLES / f"{name}.json", tmp_path / f"{name}.json")
    return tmp_path / f"{name}.json"


def _study(path: Path, capsys, *options: str) -> tuple[dict, str]:
    """A serial tolerance study of the lag-lead's T1 and T2: its --json summary and standard error."""
    argv = ["sweep", str(path), "--tolerance", "T1=+-10%", "--tolerance", "T2=normal:5%", "--serial", "--json"]
    status = main([*argv, *options])
    out, err = capsys.readouterr()
    assert status == 0, err
    return json.loads(out), err


def _exit_status(argv: list[str]) -> int:
    """The command's exit status, argparse's own refusals (SystemExit) included."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


def test_percentiles_are_numpys_and_keep_infinities():
    rng = np.random.default_rng(5)
    for n in (1, 2, 7, 100, 1001):
        values = rng.normal(3.0, 2.0, n)
        assert percentiles(values) == pytest.approx(np.percentile(values, PERCENTILES), rel=1e-15, abs=0)
    # numpy interpolates inf - inf to NaN; a percentile between an infinity and anything is the infinity
    found = percentiles(np.array([1.0, 2.0, math.inf, math.inf, math.inf]))
    assert found[:2] == pytest.approx(np.percentile([1.0, 2.0, 3.0, 3.0, 3.0], [1, 5])) and found[2:] == [math.inf] * 3
    assert percentiles(np.array([-math.inf, -math.inf, 1.0, 2.0]))[:2] == [-math.inf, -math.inf]


def test_clopper_pearson_against_its_closed_forms_and_scipys_binomial_test():
    for n in (1, 10, 200, 5000):
        assert clopper_pearson(0, n) == pytest.approx((0.0, 1 - 0.025 ** (1 / n)), rel=1e-12)  # no unmet sample
        assert clopper_pearson(n, n) == pytest.approx((0.025 ** (1 / n), 1.0), rel=1e-12)  # every sample unmet
        for k in {1, n // 3, n - 1} - {0, n}:
            exact = binomtest(k, n).proportion_ci(0.95, method="exact")
            assert clopper_pearson(k, n) == pytest.approx((exact.low, exact.high), rel=1e-9)
    with pytest.raises(ValueError):
        clopper_pearson(3, 2)


def test_a_histogram_counts_the_finite_values_and_the_infinite_beside():
    values = np.r_[np.linspace(0.0, 1.0, 50), math.inf, -math.inf, math.inf]
    found = histogram(values)
    counts, edges = np.histogram(values[np.isfinite(values)], bins=8)  # ceil(sqrt(50))
    assert found["counts"] == counts.tolist() and found["edges"] == edges.tolist()
    assert (found["below"], found["above"]) == (1, 2)
    assert len(histogram(np.linspace(0, 1, 5000))["counts"]) == 20


def test_a_studys_distributions_equal_numpys_on_its_samples(tmp_path, capsys):
    """Every row of `sweep --json`: percentiles, unmet fraction and interval, histogram
    and worst sample recomputed here from the runs' own values."""
    summary, _ = _study(_copy(tmp_path, "coebra_lag_lead"), capsys, "--samples", "60", "--seed", "3")
    runs = summary["runs"]
    assert len(runs) == 60 and not summary["failed"] and summary["settings"]["sampling"] == "random"
    for row in summary["worst_case"]:
        measures = [
            next(m for m in r["measures"] if (m["name"], m["condition"]) == (row["name"], row["condition"]))
            for r in runs
        ]
        values = np.array([float(m["value"]) for m in measures])
        assert [row["percentiles"][k] for k in PERCENTILE_KEYS] == pytest.approx(np.percentile(values, PERCENTILES))
        unmet = sum(not m["satisfied"] for m in measures)
        exact = binomtest(unmet, 60).proportion_ci(0.95, method="exact")
        assert row["unmet_samples"] == unmet and row["unmet_fraction"] == unmet / 60
        assert row["unmet_interval"] == pytest.approx([exact.low, exact.high], rel=1e-9)
        counts, edges = np.histogram(values, bins=8)
        assert row["histogram"]["counts"] == counts.tolist() and row["histogram"]["edges"] == pytest.approx(edges)
        worst = int(np.argmin(values) if measures[0]["at_least"] else np.argmax(values))
        assert row["worst_sample"] == runs[worst]["index"] and row["worst"] == values[worst]
        assert row["worst_parameters"] == runs[worst]["start"] and set(row["worst_parameters"]) == {"T1", "T2"}
    text = sweep_text(summary)
    assert "unmet % [95 % interval]" in text and all(k in text for k in PERCENTILE_KEYS)


def _columns(jobs, names: list[str], design: dict) -> np.ndarray:
    """The samples' relative deviations, a column per drawn value."""
    rows = []
    for job in jobs:
        row = []
        for name in names:
            drawn, nominal = np.atleast_1d(job.start[name]), np.atleast_1d(design[name])
            row += list(drawn / nominal - 1)
        rows.append(row)
    return np.array(rows)


def test_a_latin_hypercube_puts_one_sample_in_each_stratum_of_every_value(tmp_path):
    """Launch vehicle: KD has a value per flight condition (three columns), TA one; KD
    uniform, TA normal; each column's N strata of probability are hit once each."""
    session = load_session(_copy(tmp_path, "coebra_launch_vehicle"))
    n = 50
    jobs = tolerance_jobs(session, ["KD=+-20%", "TA=normal:10%"], n, seed=7, sampling="lhs")
    design = {p.name: p.value for p in session.model.problem.parameters}
    columns = _columns(jobs, ["KD", "TA"], design)
    assert columns.shape == (n, 4)
    probability = np.column_stack([(columns[:, :3] / 0.2 + 1) / 2, norm.cdf(columns[:, 3] / 0.1)])
    for column in probability.T:
        assert sorted(np.floor(column * n).astype(int)) == list(range(n))


@pytest.mark.parametrize("sampling", ["random", "lhs"])
def test_normal_samples_have_their_sigma_within_sampling_error(tmp_path, sampling):
    session = load_session(_copy(tmp_path, "coebra_lag_lead"))
    n, sigma = 4000, 0.05
    jobs = tolerance_jobs(session, ["T1=normal:5%", "T2=+-10%"], n, seed=11, sampling=sampling)
    t1 = np.array([j.start["T1"] for j in jobs]) / 10.0 - 1  # T1's design value is 10
    assert abs(t1.mean()) < 4 * sigma / math.sqrt(n)
    assert abs(t1.std(ddof=1) - sigma) < 4 * sigma / math.sqrt(2 * n)
    t2 = np.array([j.start["T2"] for j in jobs]) / 0.2 - 1
    assert t2.min() >= -0.1 and t2.max() <= 0.1 and abs(t2.std() - 0.1 / math.sqrt(3)) < 0.005


def test_random_uniform_samples_draw_as_earlier_versions_did(tmp_path):
    """Sample by sample, parameter by parameter in the session's order, one uniform draw
    per value: a uniform study saved before normal and Latin hypercube samples replays."""
    session = load_session(_copy(tmp_path, "coebra_launch_vehicle"))
    jobs = tolerance_jobs(session, ["TA=+-5%", "KD=+-10%"], 20, seed=4)
    rng = np.random.default_rng(4)
    for job in jobs:
        kd = np.array([0.5, 0.5, 0.5]) * (1 + rng.uniform(-0.1, 0.1, 3))  # KD comes first in the session
        ta = 0.05 * (1 + rng.uniform(-0.05, 0.05))
        assert job.start == {"KD": kd.tolist(), "TA": ta}


@pytest.mark.parametrize("sampling", ["random", "lhs"])
def test_a_study_replays_exactly_from_its_settings(tmp_path, sampling):
    session = load_session(_copy(tmp_path, "coebra_lag_lead"))
    laws = ["T1=normal:3%", "T2=+-10%"]
    jobs, settings = plan(session, "tolerance", laws, seed=9, samples=30, sampling=sampling)
    again, _ = plan(session, "tolerance", settings["tolerance"], None, settings["seed"], settings["samples"], sampling)
    assert [j.model for j in again] == [j.model for j in jobs] and settings["sampling"] == sampling
    other, _ = plan(session, "tolerance", laws, seed=10, samples=30, sampling=sampling)
    assert [j.start for j in other] != [j.start for j in jobs]


def test_the_same_seed_gives_the_same_study(tmp_path, capsys):
    path = _copy(tmp_path, "coebra_lag_lead")
    first, _ = _study(
        path, capsys, "--samples", "12", "--sampling", "lhs", "--seed", "5", "--out", str(tmp_path / "a.json")
    )
    second, _ = _study(
        path, capsys, "--samples", "12", "--sampling", "lhs", "--seed", "5", "--out", str(tmp_path / "b.json")
    )
    assert [r["start"] for r in first["runs"]] == [r["start"] for r in second["runs"]]
    assert [r["measures"] for r in first["runs"]] == [r["measures"] for r in second["runs"]]
    assert first["worst_case"] == second["worst_case"]


def test_adopt_worst_makes_the_worst_sample_the_start(tmp_path, capsys):
    path = _copy(tmp_path, "coebra_lag_lead")
    summary, _ = _study(path, capsys, "--samples", "20", "--adopt-worst", "PM1")
    row = next(r for r in summary["worst_case"] if r["name"] == "PM1")
    saved = json.loads(path.read_text())
    values = {p["name"]: p["value"] for p in saved["problem"]["parameters"]}
    assert {k: values[k] for k in ("T1", "T2")} == row["worst_parameters"] and saved["records"] == []
    assert values["T3"] == 10.0  # not toleranced: the design's
    summary, err = _study(
        path, capsys, "--samples", "20", "--seed", "1", "--adopt-worst", "--out", str(tmp_path / "w.json")
    )
    chosen = max(summary["worst_case"], key=shortfall)
    adopted = {p["name"]: p["value"] for p in json.loads((tmp_path / "w.json").read_text())["problem"]["parameters"]}
    assert {k: adopted[k] for k in ("T1", "T2")} == chosen["worst_parameters"]
    assert f"the start is now sample {chosen['worst_sample']}, the worst of {chosen['name']}" in err


def test_the_worst_row_is_the_one_that_misses_by_the_most():
    def row(name, worst, desired, at_least=True, condition="c"):
        return {"name": name, "condition": condition, "worst": worst, "desired": desired, "at_least": at_least}

    rows = [row("GM", 5.0, 6.0), row("PM", 30.0, 45.0), row("Ms", 2.4, 1.5, at_least=False), row("WC", 5.0, None)]
    assert [shortfall(r) for r in rows] == pytest.approx([1 / 6, 1 / 3, 0.6, -math.inf])
    assert worst_row(rows)["name"] == "Ms"
    rows.append(row("GM", 1.0, 6.0, condition="d"))
    assert worst_row(rows, "GM@c")["worst"] == 5.0 and worst_row(rows, "GM")["condition"] == "d"
    assert shortfall(row("Z", -2.0, 0.0)) == 2.0  # a desired value of 0: the shortfall itself
    with pytest.raises(SessionError, match="no measure row 'XX'"):
        worst_row(rows, "XX")
    assert shortfall(row("S", "nan", 0.0)) == math.inf and shortfall(row("G", "inf", 6.0)) == -math.inf


REFUSED = [
    (["--tolerance", "T1=gauss:5%"], "write NAME=+-10% (uniform within +-10 %) or NAME=normal:5%"),
    (["--tolerance", "T1=normal:-5%"], "write NAME=+-10%"),
    (["--tolerance", "T1=+-nan%"], "write NAME=+-10%"),
    (["--tolerance", "T1=+-10%", "--tolerance", "T1=normal:1%"], "T1 is given twice"),
    (["--tolerance", "X9=+-10%"], "no parameter X9"),
    (["--starts", "2", "--sampling", "lhs"], "--sampling and --adopt-worst are for a tolerance study"),
    (["--starts", "2", "--adopt-worst"], "--sampling and --adopt-worst are for a tolerance study"),
    (["--tolerance", "T1=+-1%", "--sampling", "sobol"], "invalid choice: 'sobol'"),
    (["--tolerance", "T1=+-1%", "--adopt-best", "--adopt-worst"], "not allowed with argument --adopt-best"),
]


@pytest.mark.parametrize(("options", "message"), REFUSED, ids=[" ".join(o) for o, _ in REFUSED])
def test_bad_input_is_refused_with_exit_status_2(tmp_path, capsys, options, message):
    path = _copy(tmp_path, "coebra_lag_lead")
    before = path.read_text()
    assert _exit_status(["sweep", str(path), "--serial", *options]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert path.read_text() == before


def test_adopt_worst_of_a_row_that_is_not_there_is_refused_before_the_study_and_exits_2(tmp_path, capsys):
    path = _copy(tmp_path, "coebra_lag_lead")
    before = path.read_bytes()
    argv = ["sweep", str(path), "--tolerance", "T1=+-1%", "--samples", "3", "--serial", "--adopt-worst", "GM9"]
    assert main(argv) == 2
    assert "--adopt-worst: no measure row 'GM9' in the tolerance study (rows: GM1@nominal" in capsys.readouterr().err
    assert path.read_bytes() == before  # nothing ran, nothing saved


def test_the_apps_one_line_takes_laws_sampling_and_seed():
    spec = parse_sweep("tolerance T1=normal:5% T2=+-1% samples 10 sampling lhs seed 3")
    assert spec["value"] == ["T1=normal:5%", "T2=+-1%"] and (spec["sampling"], spec["seed"]) == ("lhs", 3)
    with pytest.raises(SessionError, match="random or lhs"):
        parse_sweep("tolerance T1=+-1% sampling sobol")
    with pytest.raises(SessionError, match="write NAME"):
        parse_sweep("tolerance T1=gauss:1")
    assert (
        parse_tolerance("K=±2%").fraction == pytest.approx(0.02) and parse_tolerance("K=uniform:0.1").law == "uniform"
    )


def test_the_report_shows_the_latest_tolerance_study(tmp_path, capsys):
    from sessions.report.content import report_blocks

    path = _copy(tmp_path, "coebra_lag_lead")
    summary, _ = _study(path, capsys, "--samples", "16", "--sampling", "lhs")
    blocks = report_blocks(load_session(path))
    k = blocks.index(("h2", "Tolerance study"))
    assert "16 samples of T1=+-10%, T2=normal:5%, drawn lhs with seed 0" in blocks[k + 1][1]
    _, header, rows = blocks[k + 2]
    assert header[2:7] == PERCENTILE_KEYS and [r[0] for r in rows] == [w["name"] for w in summary["worst_case"]]
    first = summary["worst_case"][0]
    assert rows[0][4] == f"{first['percentiles']['p50']:.6g}" and rows[0][8].startswith(
        f"{first['worst_sample']}: T1 = "
    )
    kind, name, png, _ = blocks[k + 3]
    assert (kind, name) == ("figure", "tolerance") and png.startswith(b"\x89PNG")


def test_a_large_study_keeps_its_distributions_and_its_worst_samples_runs(tmp_path, capsys, monkeypatch):
    """Above `EVERY_RUN_KEPT` samples (lowered here to 40) a study keeps, of its runs, each row's
    worst sample's only: its rows (percentiles, interval, histogram, worst sample) are those of
    the same study keeping every run, the summary says so, --adopt-worst and the report work."""
    from sessions.report.content import report_blocks
    from sessions.sweeps import dispersion

    path = _copy(tmp_path, "coebra_lag_lead")
    every, _ = _study(path, capsys, "--samples", "60", "--seed", "3", "--out", str(tmp_path / "every.json"))
    monkeypatch.setattr(dispersion, "EVERY_RUN_KEPT", 40)
    options = ("--samples", "60", "--seed", "3", "--adopt-worst", "PM1", "--out", str(tmp_path / "kept.json"))
    kept, err = _study(path, capsys, *options)
    assert len(every["runs"]) == 60 and "runs_kept" not in every["settings"]
    assert kept["worst_case"] == every["worst_case"] and kept["failed"] == every["failed"] == []
    worst = sorted({row["worst_sample"] for row in kept["worst_case"]})
    assert [run["index"] for run in kept["runs"]] == worst and kept["settings"]["runs_kept"] == len(worst)
    timeless = lambda runs: [{k: v for k, v in run.items() if k != "seconds"} for run in runs]  # noqa: E731
    assert timeless(kept["runs"]) == timeless(run for run in every["runs"] if run["index"] in worst)
    note = f"the runs of {len(worst)} of 60 samples kept (each row's worst sample)"
    assert note in kept["settings"]["note"] and note in err
    row = next(r for r in kept["worst_case"] if r["name"] == "PM1")
    saved = json.loads((tmp_path / "kept.json").read_text())
    assert {p["name"]: p["value"] for p in saved["problem"]["parameters"] if p["name"] in ("T1", "T2")} == row[
        "worst_parameters"
    ]
    assert f"the start is now sample {row['worst_sample']}, the worst of PM1" in err
    blocks = report_blocks(load_session(tmp_path / "every.json"))
    assert blocks[blocks.index(("h2", "Tolerance study")) + 1][1].startswith("60 samples of T1=+-10%")


def test_a_large_studys_failed_runs_are_counted_and_the_first_kept(monkeypatch):
    """Failed samples: every index in ``failed``, the first `FAILED_RUNS_KEPT` runs kept (their reasons)."""
    from sessions.sweeps import dispersion
    from sessions.sweeps.dispersion import Tally

    monkeypatch.setattr(dispersion, "EVERY_RUN_KEPT", 10)
    monkeypatch.setattr(dispersion, "FAILED_RUNS_KEPT", 2)

    def run(k: int) -> dict:
        if k % 3 == 0:
            return {"index": k, "status": "failed", "reason": "cancelled" if k > 20 else "singular", "measures": []}
        measure = {"name": "GM", "kind": "gain_margin_db", "condition": "c", "desired": 6.0, "at_least": True}
        value = 10.0 - abs(k - 13)
        return {
            "index": k,
            "status": "running",
            "start": {"K": k},
            "measures": [{**measure, "value": value, "satisfied": value >= 6}],
        }

    runs = [run(k) for k in range(30)]
    tally = Tally.of(runs)
    assert tally.thinned and tally.failed == list(range(0, 30, 3)) and tally.finished == 30 - 3  # 21, 24, 27 cancelled
    assert [r["index"] for r in tally.runs()] == [0, 3, 29]  # the first two failed, the worst (GM -6 dB)
    every = Tally(every_run=True)
    for r in runs:
        every.add(r)
    assert tally.rows() == every.rows() and every.runs() == runs and not every.thinned
    assert tally.rows()[0]["samples"] == 20 and tally.rows()[0]["worst_parameters"] == {"K": 29}


def test_a_large_study_counts_its_samples_not_the_runs_it_keeps():
    from sessions.sweeps.dispersion import run_count

    kept = {"runs": [{}] * 3, "settings": {"samples": 100_000, "runs_kept": 3}}
    every = {"runs": [{}] * 2000, "settings": {"samples": 2000}}
    assert run_count(kept) == "100000 runs (3 kept)"
    assert run_count(every) == "2000 runs"
    assert run_count({"runs": [{}] * 16, "settings": {}}) == "16 runs"  # a starts sweep


@pytest.mark.parametrize("laws", [["A=+-10%", "B=+-5%"], ["A=normal:10%", "B=normal:3%", "C=normal:1%"]])
def test_draws_in_one_call_are_the_sample_at_a_time_draws(laws):
    """Issue 53, section 3: laws of one kind are drawn for every sample in one call (1 000 000
    samples: 15 s -> 0.1 s); the values are the sample-at-a-time loop's, bit for bit (its order:
    sample after sample, law after law, a value per condition)."""
    from sessions.sweeps.sampling import _at_random, deviations

    tolerances = [parse_tolerance(text) for text in laws]
    sizes = [1, 3, 2][: len(laws)]
    for seed in (0, 9):
        rng = np.random.default_rng(seed)
        loop = [np.empty((500, size)) for size in sizes]
        for k in range(500):
            for law, drawn in zip(tolerances, loop):
                drawn[k] = _at_random(rng, law, drawn.shape[1])
        for got, want in zip(deviations(tolerances, sizes, 500, "random", seed), loop, strict=True):
            assert np.array_equal(got, want)

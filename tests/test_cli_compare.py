"""`loopcraft compare`: two runs of coebra_lag_lead.json from different starts
side by side; the measures are checked against python-control's margins of
each final design (built here from the example's formula)."""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np
import pytest

from sessions.runner import run_session
from sessions.store import load_session, save_session
from tui.cli import main

EXAMPLE = Path(__file__).resolve().parents[1] / "sessions" / "examples" / "coebra_lag_lead.json"
PLANT = control.tf([16000.0], [1.0, 28.0, 160.0, 0.0])


def _run_from(tmp_path: Path, name: str, start: dict[str, float]) -> Path:
    data = json.loads(EXAMPLE.read_text())
    for p in data["problem"]["parameters"]:
        p["value"] = start.get(p["name"], p["value"])
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(data))
    session = load_session(path)
    run_session(session, until_done=True, autosave=False)
    save_session(session, path)
    return path


def _python_control_margins(parameters: dict) -> dict:
    T1, T2, T3, T4 = (parameters[k] for k in ("T1", "T2", "T3", "T4"))
    compensator = control.tf(np.polymul([T1, 1.0], [T2, 1.0]), np.polymul([T3, 1.0], [T4, 1.0]))
    gm, pm, _, _, wc, _ = control.stability_margins(compensator * PLANT)
    return {"gain_margin_db": 20 * np.log10(gm), "phase_margin_deg": pm, "crossover_frequency": wc}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("compare")
    return (
        _run_from(folder, "report_start", {}),
        _run_from(folder, "other_start", {"T1": 2.0, "T2": 0.05, "T3": 30.0, "T4": 0.01}),
    )


def test_two_runs_side_by_side(runs, capsys):
    a, b = runs
    assert main(["compare", str(a), str(b), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    for side, path in (("a", a), ("b", b)):
        session = load_session(path)
        final = session.model.records[-1]["parameters"]
        assert data[side]["parameters"] == final and data[side]["iteration"] == session.model.current_iteration
        expected = _python_control_margins(final)
        for row in data["rows"]:
            if row["kind"] in expected and row[side] is not None:
                assert row[side]["value"] == pytest.approx(expected[row["kind"]], rel=1e-9)
    for row in data["rows"]:
        if row["a"] and row["b"]:
            assert row["difference"] == pytest.approx(row["b"]["value"] - row["a"]["value"])
    met = {s: sum(r[s]["satisfied"] for r in data["rows"] if r[s]) for s in "ab"}
    assert (data["a"]["met"], data["b"]["met"]) == (met["a"], met["b"])
    assert data["better"] == ("a" if met["a"] > met["b"] else "b" if met["b"] > met["a"] else "tie")
    assert data["a"]["parameters"] != data["b"]["parameters"]


def test_two_iterations_of_one_session(runs, capsys):
    """Iteration 0 (unstable: PM -28.6 deg) against the last, which meets every target."""
    a, _ = runs
    last = load_session(a).model.current_iteration
    assert main(["compare", str(a), "--iterations", "0", str(last), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    pm = next(r for r in data["rows"] if r["kind"] == "phase_margin_deg")
    assert pm["a"]["value"] == pytest.approx(
        _python_control_margins({"T1": 10.0, "T2": 0.2, "T3": 10.0, "T4": 0.2})["phase_margin_deg"], rel=1e-9
    )
    assert data["better"] == "b" and data["b"]["met"] == data["b"]["measures"]
    assert main(["compare", str(a), "--iterations", "0", str(last)]) == 0
    text = capsys.readouterr().out
    assert "B meets more targets" in text and "phase_margin_deg" in text


@pytest.mark.parametrize(
    "args, message",
    [
        (["--iterations", "0", "99"], "--iteration: 99 is outside"),
        ([], "give a second session"),
    ],
)
def test_bad_compare_options_exit_2(runs, capsys, args, message):
    assert main(["compare", str(runs[0]), *args]) == 2
    assert message in capsys.readouterr().err


def test_different_problems_are_said_to_differ_and_where_before_the_verdict(runs, tmp_path, capsys):
    """Another plant and another target: compare says the problems differ, naming both
    places, before which design meets more; two runs of one problem say nothing of it."""
    data = json.loads(runs[1].read_text())
    blocks = data["problem"]["conditions"][0]["plant"]["blocks"]
    plant = next(b for b in blocks if "16000" in json.dumps(b["transfer"]))
    plant["transfer"] = json.loads(json.dumps(plant["transfer"]).replace("16000", "8000"))
    data["problem"]["targets"][0]["bands"][0]["desired"] = 99.0
    other = tmp_path / "other_problem.json"
    other.write_text(json.dumps(data))

    assert main(["compare", str(runs[0]), str(other)]) == 0
    out = capsys.readouterr().out
    differ = out.index("the problems differ")
    assert differ < out.index("meets more") if "meets more" in out else differ < out.index("meet as many")
    assert "16000" in out and "8000" in out and ".targets[0].bands[0].desired: 10.0 in A, 99.0 in B" in out
    assert main(["compare", str(runs[0]), str(other), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["same_problem"] is False and len(data["differences"]) == 2

    assert main(["compare", str(runs[0]), str(runs[1]), "--json"]) == 0
    same = json.loads(capsys.readouterr().out)
    assert same["same_problem"] is True and same["differences"] == []  # other starts, one problem


def test_the_stability_row_names_and_both_desired_values(tmp_path, capsys):
    """The example's start is unstable (poles 3.97 +- 20.7j): compare keeps slp's and the report's
    stability row (STAB = -max Re p, python-control's closed-loop poles), names the rows as every
    command does (WC1, GM1, PM1) and shows both desired values where the sessions differ (10 / 8)."""
    data = json.loads(EXAMPLE.read_text())
    gain = next(t for t in data["problem"]["targets"] if t["measure"] == "gain_margin_db")
    gain["bands"][0]["desired"] = 8.0
    other = tmp_path / "gm8.json"
    other.write_text(json.dumps(data))
    assert main(["compare", str(EXAMPLE), str(other), "--json"]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)["rows"]}
    assert {"WC1", "GM1", "PM1", "STAB"} <= set(rows)
    start = {p["name"]: p["value"] for p in data["problem"]["parameters"]}
    T1, T2, T3, T4 = (start[k] for k in ("T1", "T2", "T3", "T4"))
    compensator = control.tf(np.polymul([T1, 1.0], [T2, 1.0]), np.polymul([T3, 1.0], [T4, 1.0]))
    abscissa = -max(control.poles(control.feedback(compensator * PLANT, 1)).real)
    assert abscissa < 0 and rows["STAB"]["a"]["value"] == pytest.approx(abscissa, rel=1e-9)
    assert rows["STAB"]["a"]["satisfied"] is False
    assert (rows["GM1"]["desired_a"], rows["GM1"]["desired_b"]) == (10.0, 8.0)
    assert main(["compare", str(EXAMPLE), str(other)]) == 0
    text = capsys.readouterr().out
    assert "A 1 of 4" in text
    gm_line = next(line for line in text.splitlines() if " GM1 " in line)
    assert "10 / 8" in gm_line

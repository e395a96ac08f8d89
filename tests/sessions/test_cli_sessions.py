"""`loopcraft run | replay | report | examples`, in-process (the tests'
algorithm is registered only here) and as a subprocess for bad input."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tui.cli import main


def test_run_json_saves_records_and_reports(matching, tmp_path, capsys):
    out = tmp_path / "out.json"
    assert main(["run", str(matching), "--until-done", "--out", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {
        "algorithm",
        "status",
        "iterations",
        "parameters",
        "objective",
        "measures",
        "counters",
        "design_notes",
    }
    assert data["algorithm"] == "gradient" and data["status"] == "converged"
    assert data["parameters"]["K"] == pytest.approx(4.0) and data["objective"] < 1e-24
    assert {"name", "kind", "condition", "value", "target", "desired", "satisfied", "frequency"} == set(
        data["measures"][0]
    )
    assert data["counters"]["evaluations"] >= 1
    saved = json.loads(out.read_text())
    assert saved["current_iteration"] == data["iterations"] == len(saved["records"])
    assert json.loads(matching.read_text())["records"] == []  # --out leaves the input alone


def test_replay_exit_codes(matching, tmp_path, capsys):
    assert main(["run", str(matching), "--iterations", "3"]) == 0
    assert main(["replay", str(matching)]) == 0
    doc = json.loads(matching.read_text())
    doc["records"][1]["measures"][0]["value"] += 1e-6
    matching.write_text(json.dumps(doc))
    assert main(["replay", str(matching)]) == 1
    assert "iteration 2 diverges: measure PM1" in capsys.readouterr().err
    (tmp_path / "junk.json").write_text("{")
    assert main(["replay", str(tmp_path / "junk.json")]) == 2


@pytest.mark.parametrize("fmt", ["text", "json", "csv"])
def test_report_formats(matching, capsys, fmt):
    main(["run", str(matching), "--iterations", "2"])
    capsys.readouterr()
    assert main(["report", str(matching), "--iteration", "1", "--format", fmt]) == 0
    out = capsys.readouterr().out
    assert "phase_margin_deg" in out
    if fmt == "json":
        data = json.loads(out)
        assert data["iteration"] == 1
        row = data["measures"][0]  # the key other programs read, beside the row's own name
        assert row["target"] == row["desired"] == 45.0


def test_report_iteration_out_of_range(matching, capsys):
    assert main(["report", str(matching), "--iteration", "5"]) == 2
    assert "outside 0..0" in capsys.readouterr().err


def test_examples_list_and_copy(tmp_path, capsys):
    assert main(["examples", "--copy", str(tmp_path / "ex")]) == 0
    out = capsys.readouterr().out
    assert "report003_lag_lead.json" in out
    assert (tmp_path / "ex" / "report003_lag_lead.json").exists()


@pytest.mark.parametrize(
    "args",
    [
        ["run", "missing.json"],
        ["report", "missing.json"],
        ["replay", "missing.json"],
        ["run", "sessions/examples/report003_lag_lead.json", "--out", "/tmp/x.json", "--algorithm", "nonesuch"],
    ],
)
def test_bad_input_exits_2_with_one_line(args):
    out = subprocess.run([sys.executable, "-m", "tui.cli"] + args, capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr


def test_a_newer_autosave_is_mentioned(matching, capsys):
    from sessions.runner import run_session
    from sessions.store import load_session

    run_session(load_session(matching), iterations=1)  # autosaves, does not save
    assert main(["report", str(matching)]) == 0
    assert "matching.json.autosave is newer than matching.json" in capsys.readouterr().err


def test_cip_report_in_the_listing_layout(tmp_path, capsys):
    assert main(["examples", "--copy", str(tmp_path)]) == 0
    session = str(tmp_path / "cip_launch_vehicle.json")
    capsys.readouterr()
    assert main(["report", session]) == 0
    initial = capsys.readouterr().out
    assert "ITERATION NO.    0" in initial and "RELATIVE STABILITY INFORMATION" in initial
    assert "ATTENUATED FREQUENCY INFORMATION" in initial
    assert "MARGIN RADIUS NO.   1 =    0.90693   FREQUENCY =    0.01852 HZ" in initial
    assert "UNMET REQUIREMENTS: 4" in initial
    assert main(["run", session, "--iterations", "2"]) == 0
    capsys.readouterr()
    assert main(["report", session]) == 0
    after = capsys.readouterr().out
    assert "ITERATION NO.    2" in after and "PARTIALS WITH RESPECT TO X" in after
    assert "PARTIALS WITH RESPECT TO Y" in after and "multiplied out" in after


def test_tradeoff_command(tmp_path, capsys):
    assert main(["examples", "--copy", str(tmp_path)]) == 0
    capsys.readouterr()
    assert (
        main(
            [
                "tradeoff",
                str(tmp_path / "seidel_inlet_pi.json"),
                "--penalty",
                "q2",
                "--values",
                "1e-4",
                "1e-3",
                "--json",
            ]
        )
        == 0
    )
    points = json.loads(capsys.readouterr().out)
    assert [p["penalty"] for p in points] == [1e-4, 1e-3]
    assert points[0]["parameters"]["b1"] == pytest.approx(47.41, rel=0.01)
    assert main(["tradeoff", str(tmp_path / "cip_launch_vehicle.json"), "--penalty", "q2", "--values", "1"]) == 2


def test_qcg_report_prints_both_cost_conventions(tmp_path, capsys):
    assert main(["examples", "--copy", str(tmp_path)]) == 0
    session = str(tmp_path / "seidel_inlet_pi.json")
    assert main(["run", session, "--until-done"]) == 0
    capsys.readouterr()
    assert main(["report", session]) == 0
    out = capsys.readouterr().out
    assert "F= 3.1228" in out and "= 2 pi C" in out and "C= 4.970" in out
    assert "IER = 0" in out and "HZ" in out

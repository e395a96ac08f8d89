"""slp sessions: the schema's new fields, equality terms, the generated
launch-vehicle example, and `loopcraft run --adopt --set` for the second phase."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from sessions.errors import SessionError
from sessions.runner import replay
from sessions.store import load_session
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def test_launch_vehicle_example_is_generated_by_its_script(tmp_path):
    from sessions.examples.coebra_launch_vehicle import write_example

    write_example(tmp_path)
    name = "coebra_launch_vehicle.json"
    assert json.loads((tmp_path / name).read_text()) == json.loads((EXAMPLES / name).read_text())


def test_time_response_and_required_values_are_read(tmp_path):
    session = load_session(EXAMPLES / "coebra_launch_vehicle.json")
    targets = session.problem.targets
    assert targets[0].sense == "at_most" and not targets[0].at_least
    assert targets[0].bands[0].required == -6.0 and targets[0].bands[0].desired == -8.0
    peak = targets[-1]
    assert peak.measure == "peak_response" and not peak.requirement
    assert peak.response.input == "alpha_w" and peak.response.profile == ((0.0, 0.0, 0.05), (2.0, 0.0, -0.05))


def _with_equality(tmp_path: Path, terms: dict) -> Path:
    doc = json.loads((EXAMPLES / "coebra_launch_vehicle.json").read_text())
    doc["problem"]["equalities"] = [{"terms": terms, "value": 0.0}]
    path = tmp_path / "lv.json"
    path.write_text(json.dumps(doc))
    return path


def test_equality_terms_name_conditions(tmp_path):
    problem = load_session(_with_equality(tmp_path, {"KL[max-q]": 1.0, "KL[2]": -1.0})).problem
    assert problem.equalities[0].terms == (("KL", 1, 1.0), ("KL", 2, -1.0))
    A, b = problem.equality_system()
    assert A.shape == (1, len(problem.free_slots())) and sorted(A[0][A[0] != 0]) == [-1.0, 1.0]


@pytest.mark.parametrize(
    "terms, message",
    [
        ({"KL[cruise]": 1.0}, "problem.equalities[0].terms.KL[cruise]: no condition 'cruise'"),
        ({"KL": 1.0}, "equalities[0]: 'KL' has one value per condition"),
        ({"TA[max-q]": 1.0}, "equalities[0]: 'TA' is shared by all conditions"),
        ({"XX": 1.0}, "equalities[0]: unknown parameter 'XX'"),
    ],
)
def test_bad_equalities_name_their_path(tmp_path, terms, message):
    with pytest.raises(SessionError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_session(_with_equality(tmp_path, terms))


def test_time_measure_without_response_is_refused(tmp_path):
    doc = json.loads((EXAMPLES / "coebra_lag_lead.json").read_text())
    doc["problem"]["targets"].append({"measure": "rise_time", "bands": [{"desired": 0.3}]})
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(SessionError, match="'rise_time' needs a response"):
        load_session(path)


@pytest.mark.long
@pytest.mark.slow
def test_run_adopt_set_continues_with_load_relief(tmp_path, capsys):
    """Phase 1 to its end, then phase 2 from its design: `--adopt --set objective=load_relief`."""
    source = tmp_path / "lv.json"
    shutil.copy(EXAMPLES / "coebra_launch_vehicle.json", source)
    first = tmp_path / "phase1.json"
    assert main(["run", str(source), "--until-done", "--out", str(first), "--json"]) == 0
    phase1 = json.loads(capsys.readouterr().out)
    assert all(m["satisfied"] for m in phase1["measures"])
    second = tmp_path / "phase2.json"
    assert (
        main(
            [
                "run",
                str(first),
                "--adopt",
                "--set",
                "objective=load_relief",
                "--until-done",
                "--out",
                str(second),
                "--json",
            ]
        )
        == 0
    )
    phase2 = json.loads(capsys.readouterr().out)
    saved = json.loads(second.read_text())
    assert saved["algorithm"]["settings"]["objective"] == "load_relief"
    start = {p["name"]: p["value"] for p in saved["problem"]["parameters"]}
    assert start == phase1["parameters"]
    assert all(m["satisfied"] for m in phase2["measures"])
    before = {m["condition"]: m["value"] for m in phase1["measures"] if m["kind"] == "peak_response"}
    after = {m["condition"]: m["value"] for m in phase2["measures"] if m["kind"] == "peak_response"}
    assert after["max-q"] <= 0.9 * before["max-q"]
    assert replay(load_session(second)).ok
    assert not (tmp_path / "phase1.json.autosave").exists()


def test_bad_set_is_one_line(tmp_path, capsys):
    source = tmp_path / "kuo.json"
    shutil.copy(EXAMPLES / "coebra_kuo_digital.json", source)
    assert main(["run", str(source), "--set", "objective"]) == 2
    assert "write NAME=VALUE" in capsys.readouterr().err
    assert main(["run", str(source), "--set", "no_such=1"]) == 2
    assert "unknown setting(s) no_such" in capsys.readouterr().err


def test_report_shows_the_minor_loop_and_partials(tmp_path, capsys):
    source = tmp_path / "lag.json"
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", source)
    assert main(["report", str(source)]) == 0
    start = capsys.readouterr().out
    assert "ITERATION 0" in start and "STAB" in start and " NO " in start
    assert main(["run", str(source), "--iterations", "2"]) == 0
    capsys.readouterr()
    assert main(["report", str(source)]) == 0
    text = capsys.readouterr().out
    assert "MAJOR 1  MINOR 2" in text and "analytic" in text and "finite difference" in text

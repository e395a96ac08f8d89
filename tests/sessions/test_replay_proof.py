"""`replay` proves what it claims: every field of every record, the order of
the records, the settings that made them and the saved state are compared;
numerical noise on a zero is not a divergence."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from sessions.errors import SessionError
from sessions.runner import difference, replay, run_session
from sessions.store import load_session, save_session
from tui.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "report003_lag_lead.json"
START = {"z1": 2.0, "z2": 10.0, "p1": 0.5, "p2": 20.0}  # away from the hand design: three running iterations


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> dict:
    """Report 003's lag-lead session after 3 iterations, as saved."""
    data = json.loads(EXAMPLE.read_text())
    for parameter in data["problem"]["parameters"]:
        parameter["value"] = START[parameter["name"]]
    path = tmp_path_factory.mktemp("replay") / "lag_lead.json"
    path.write_text(json.dumps(data))
    session = load_session(path)
    assert len(run_session(session, 3, autosave=False)) == 3
    save_session(session)
    return json.loads(path.read_text())


def _replayed(doc: dict, tmp_path: Path):
    """Replay of the edited document; what loading refuses (records out of order, a state
    of another iteration) is put in the loaded model: replay names it all the same."""
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(doc))
    try:
        session = load_session(path)
    except SessionError:
        original = {
            **doc,
            "records": [{**r, "iteration": k} for k, r in enumerate(doc["records"], start=1)],
            "state": {**doc["state"], "iteration": doc["current_iteration"]},
        }
        path.write_text(json.dumps(original))
        session = load_session(path)
        session.model.records[:] = doc["records"]
        session.model.state = doc["state"]
    return replay(session)


def _changed(value):
    """A value one small edit away: numbers by 1e-6 relative, the rest by kind."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value * (1 + 1e-6) if value else 1e-3
    if isinstance(value, str):
        return "converged" if value == "running" else value + "x"
    if value is None:
        return 1.0
    if isinstance(value, list):
        return value + [0.5]
    return {**value, "added": 1}


def _edit(node, path: tuple):
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = _changed(node[path[-1]])


RECORD_FIELDS = [
    (("iteration",), "out of order"),
    (("status",), "status: 'converged' recorded, 'running' now"),
    (("parameters", "z1"), "parameter z1: "),
    (("objective",), "objective: 1.0 recorded, None now"),
    (("step_size",), "step_size"),
    (("direction", 0), "direction[0]"),
    (("direction",), "direction: 5 entries recorded, 4 now"),
    (("counters", "trials"), "counters.trials"),
    (("counters",), "counters.added"),
    (("reason",), "reason"),
    (("extra", "unmet"), "extra.unmet"),
    (("extra", "best", "smallest_stability_margin"), "extra.best.smallest_stability_margin"),
    (("extra", "compensators", 0, "numerator", 1), "extra.compensators[0].numerator[1]"),
    (("extra", "matched", 2, "active_after"), "extra.matched[2].active_after"),
    (("settings", "max_iterations"), "settings mismatch"),
] + [
    (("measures", 1, name), f"measures[1].{name}")
    for name in ("name", "kind", "condition", "value", "desired", "satisfied", "frequency", "at_least", "method")
]


@pytest.mark.parametrize(
    "path, named", RECORD_FIELDS, ids=lambda p: ".".join(map(str, p)) if isinstance(p, tuple) else None
)
def test_every_field_of_a_record_is_compared(recorded, tmp_path, path, named):
    doc = copy.deepcopy(recorded)
    _edit(doc["records"][1], path)
    result = _replayed(doc, tmp_path)
    assert not result.ok and named in result.message
    assert result.message.startswith("settings mismatch" if path[0] == "settings" else "iteration 2 diverges")


def test_a_frequency_divergence_shows_both_values(recorded, tmp_path):
    doc = copy.deepcopy(recorded)
    measure = doc["records"][2]["measures"][0]
    old, measure["frequency"] = measure["frequency"], measure["frequency"] * (1 + 1e-6)
    message = _replayed(doc, tmp_path).message
    assert f"{measure['frequency']!r} recorded, {old!r} now" in message
    assert message.startswith(f"iteration 3 diverges: measure {measure['name']} ({measure['kind']}, nominal)")


@pytest.mark.parametrize(
    "path, named",
    [
        (("x", 0), "state.x[0]"),
        (("memory", "step"), "state.memory.step"),
        (("memory", "requirements", 1, "frequency"), "state.memory.requirements[1].frequency"),
        (("iteration",), "state.iteration"),
    ],
)
def test_the_saved_state_is_compared(recorded, tmp_path, path, named):
    doc = copy.deepcopy(recorded)
    _edit(doc["state"], path)
    result = _replayed(doc, tmp_path)
    assert not result.ok and "the saved state diverges" in result.message and named in result.message


def test_the_order_of_the_records_is_compared(recorded, tmp_path):
    doc = copy.deepcopy(recorded)
    doc["records"][0], doc["records"][1] = doc["records"][1], doc["records"][0]
    result = _replayed(doc, tmp_path)
    assert not result.ok and "iteration 1 diverges" in result.message and "out of order" in result.message


def test_a_settings_change_that_leaves_the_records_alone_is_a_mismatch(recorded, tmp_path, capsys):
    """200 or 300 iterations at most: three iterations are the same, yet these
    records were not made with these settings."""
    doc = copy.deepcopy(recorded)
    doc["algorithm"]["settings"]["max_iterations"] = 300
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(doc))
    assert main(["replay", str(path)]) == 1
    err = capsys.readouterr().err
    assert "settings mismatch" in err and "settings.max_iterations: 200 recorded, 300 now" in err


def test_the_untouched_session_reproduces(recorded, tmp_path, capsys):
    path = tmp_path / "same.json"
    path.write_text(json.dumps(recorded))
    assert main(["replay", str(path)]) == 0
    assert "all 3 recorded iterations reproduce, and the saved state" in capsys.readouterr().out


def test_noise_on_a_zero_is_not_a_divergence(recorded, tmp_path):
    doc = copy.deepcopy(recorded)
    points = doc["state"]["memory"]["requirements"][0]["points"][0]
    assert points[1] == 0.0
    points[1] = 1e-13
    assert _replayed(doc, tmp_path).ok
    assert difference({"a": [0.0, "nan"]}, {"a": [-3e-13, float("nan")]}) is None
    assert difference({"a": 0.0}, {"a": 1e-9}) == "a: 0.0 recorded, 1e-09 now"
    assert difference({"a": 1}, {"a": True}) is not None and difference(["inf"], [float("inf")]) is None


def test_errors_exit_2_and_divergence_1(recorded, tmp_path, capsys):
    doc = copy.deepcopy(recorded)
    doc["records"][0]["parameters"]["z1"] += 1.0
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(doc))
    assert main(["replay", str(path)]) == 1
    doc["algorithm"]["settings"]["nonesuch"] = 1  # the algorithm cannot be made: an error
    path.write_text(json.dumps(doc))
    assert main(["replay", str(path)]) == 2
    assert "unknown setting(s) nonesuch" in capsys.readouterr().err

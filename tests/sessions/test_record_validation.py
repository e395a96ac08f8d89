"""Records and the state are checked when a session loads, like the problem:
a corrupted record is a `SessionError` naming the file and its JSON path,
never a crash later in the History tab, `replay` or `report`."""

from __future__ import annotations

import copy
import json

import pytest

from engine.errors import EngineError
from engine.stepping.protocol import StepRecord
from sessions.errors import SessionError
from sessions.runner import run_session
from sessions.store import load_session, save_session
from tui.cli import main


@pytest.fixture
def ran(matching):
    """The matching session after three iterations, saved."""
    session = load_session(matching)
    run_session(session, iterations=3, autosave=False)
    save_session(session)
    return matching


def _corrupt(path, change):
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))
    return path.read_bytes()


def _set(*keys_and_value):
    *keys, value = keys_and_value

    def change(doc):
        node = doc
        for key in keys[:-1]:
            node = node[key]
        if value is DELETE:
            del node[keys[-1]]
        else:
            node[keys[-1]] = value

    return change


DELETE = object()

CASES = [
    (
        _set("records", 1, "parameters", "K", "abc"),
        r"records\[1\]\.parameters\.K: expected a finite number, got the string \"abc\"",
    ),
    (_set("records", 1, "parameters", "K", "inf"), r"records\[1\]\.parameters\.K: expected a finite number, got inf"),
    (
        _set("records", 1, "parameters", "K", None),
        r"records\[1\]\.parameters\.K: expected a finite number, got null",
    ),
    (
        _set("records", 1, "parameters", "K", [1.0, 2.0]),
        r"records\[1\]\.parameters\.K: expected a number \(K has one value for all conditions\), got a list of 2",
    ),
    (_set("records", 1, "parameters", "Z", 1.0), r"records\[1\]\.parameters\.Z: not a parameter of the problem"),
    (_set("records", 1, "parameters", [1, 2]), r"records\[1\]\.parameters: expected an object, got a list"),
    (_set("records", 0, "status", "done"), r"records\[0\]\.status: expected one of running, converged"),
    (_set("records", 0, "status", DELETE), r"records\[0\]\.status: missing"),
    (_set("records", 2, "iteration", 5), r"records\[2\]\.iteration: expected 3 \(records are numbered 1\.\.n"),
    (_set("records", 2, "iteration", "3"), r"records\[2\]\.iteration: expected an integer >= 0, got the string \"3\""),
    (
        _set("records", 1, "measures", 0, "value", "abc"),
        r"records\[1\]\.measures\[0\]\.value: expected a number, got the string",
    ),
    (
        _set("records", 1, "measures", 0, "satisfied", "yes"),
        r"records\[1\]\.measures\[0\]\.satisfied: expected true or false, got the string \"yes\"",
    ),
    (_set("records", 1, "measures", 0, "name", DELETE), r"records\[1\]\.measures\[0\]\.name: missing"),
    (
        _set("records", 1, "measures", 0, "name", 7),
        r"records\[1\]\.measures\[0\]\.name: expected a string, got the number 7",
    ),
    (_set("records", 1, "measures", 0, "frequency", "x"), r"records\[1\]\.measures\[0\]\.frequency: expected a number"),
    (
        _set("records", 1, "measures", 0, "colour", "red"),
        r"records\[1\]\.measures\[0\]\.colour: not a field of a measure",
    ),
    (_set("records", 1, "measures", {}), r"records\[1\]\.measures: expected a list, got an object"),
    (_set("records", 1, "measures", [3]), r"records\[1\]\.measures\[0\]: expected an object, got the number 3"),
    (_set("records", 1, "counters", "evaluations", 1.5), r"records\[1\]\.counters\.evaluations: expected an integer"),
    (_set("records", 1, "objective", "low"), r"records\[1\]\.objective: expected a number, got the string \"low\""),
    (_set("records", 1, "direction", ["x"]), r"records\[1\]\.direction\[0\]: expected a number"),
    (_set("records", 1, "reason", 3), r"records\[1\]\.reason: expected a string, got the number 3"),
    (_set("records", 1, "extra", []), r"records\[1\]\.extra: expected an object, got a list"),
    (_set("records", 1, "colour", "red"), r"records\[1\]\.colour: not a field of a record"),
    (_set("records", 1, []), r"records\[1\]: Input should be a valid dictionary"),
    (_set("state", "iteration", 2), r"state\.iteration: 2, but current_iteration is 3"),
    (_set("current_iteration", 2), r"state\.iteration: 3, but current_iteration is 2"),
    (_set("current_iteration", 4), r"current_iteration 4 exceeds the 3 records"),
]


@pytest.mark.parametrize("change, message", CASES)
def test_a_corrupted_record_is_a_load_error_naming_its_path(ran, change, message):
    before = _corrupt(ran, change)
    with pytest.raises(SessionError, match=rf"^{ran}: {message}"):
        load_session(ran)
    assert ran.read_bytes() == before


def test_measure_values_may_be_non_finite_as_written(ran):
    """'nan' is "no crossing"; the strings 'inf', '-inf', 'nan' are how records write non-finite floats."""

    def change(doc):
        row = doc["records"][1]["measures"][0]
        row["value"], row["frequency"], row["desired"] = "nan", "nan", "-inf"
        doc["records"][1]["objective"] = "inf"

    _corrupt(ran, change)
    record = load_session(ran).records[1]
    row = record.measures[0]
    assert row.value != row.value and row.frequency != row.frequency and row.desired == float("-inf")
    assert record.objective == float("inf")


def test_a_per_condition_parameter_has_one_value_per_condition(matching_dict, tmp_path):
    second = copy.deepcopy(matching_dict["problem"]["conditions"][0])
    second["name"] = "heavy"
    matching_dict["problem"]["conditions"].append(second)
    matching_dict["problem"]["parameters"][0]["value"] = [1.0, 2.0]
    record = {"iteration": 1, "status": "running", "parameters": {"K": [1.0, 2.0], "T": 0.1}, "measures": []}
    matching_dict.update(records=[record], current_iteration=1)
    path = tmp_path / "two.json"
    path.write_text(json.dumps(matching_dict))
    assert load_session(path).records[0].parameters["K"] == [1.0, 2.0]
    for wrong, said in (
        ([1.0], r"expected a list of 2 numbers \(one per condition\), got a list of 1"),
        (3.0, r"expected a list of 2 numbers \(one per condition\), got the number 3\.0"),
        ([1.0, "a"], r"\[1\]: expected a finite number, got the string \"a\""),
    ):
        record["parameters"]["K"] = wrong
        path.write_text(json.dumps(matching_dict))
        with pytest.raises(SessionError, match=rf"records\[0\]\.parameters\.K.*{said}"):
            load_session(path)


@pytest.mark.parametrize("command", [["replay"], ["report", "--iteration", "2"], ["report"], ["run"]])
def test_the_cli_says_one_line_and_exits_2(ran, capsys, command):
    _corrupt(ran, _set("records", 1, "parameters", "K", "abc"))
    assert main([command[0], str(ran), *command[1:]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'records[1].parameters.K: expected a finite number, got the string "abc"' in err[0]


def _leaf_paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaf_paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _leaf_paths(v, prefix + (i,))


WRONG = [DELETE, None, "abc", "nan", 1.5, -1, True, [], {}, [1, "x"], {"a": 1}]


def test_step_record_from_json_raises_only_engine_error(ran):
    """Every field deleted or replaced by each wrong value: a record or an `EngineError`."""
    valid = json.loads(ran.read_text())["records"][1]
    assert StepRecord.from_json(valid).to_json() == {k: v for k, v in valid.items() if k != "settings"}
    for path in list(_leaf_paths(valid))[1:]:
        for value in WRONG:
            data = copy.deepcopy(valid)
            _set(*path, value)(data)
            try:
                StepRecord.from_json(data)
            except EngineError as exc:
                assert str(exc).startswith("record")
    for data in (None, [], "x", 3):
        with pytest.raises(EngineError, match="record: expected an object"):
            StepRecord.from_json(data)

"""Messages as docs/cli.md promises them (issue 50's fuzz signatures): one line, exit status 2,
the input's JSON path without the schema's tags, JSON values as JSON, no Python exception
names, echoes cut short, a wrong --adopt-worst refused before any sample runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from engine.errors import shown_json
from sessions.errors import in_words
from sessions.sweeps.cluster import reason
from tui.cli import main


def _refused(capsys, argv: list[str]) -> str:
    capsys.readouterr()
    with pytest.raises(SystemExit) as exited:
        status = main(argv)
        raise SystemExit(status)
    err = capsys.readouterr().err
    assert exited.value.code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.fixture
def lead(tmp_path: Path) -> Path:
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s*(s+1))", "--compensator", "lead"]) == 0
    return path


@pytest.mark.parametrize(
    "argv, words",
    [
        (["export", "x.json"], "loopcraft export: error: the following arguments are required: --to"),
        (["analyze", "--points", "x"], "loopcraft analyze: error: argument --points: invalid int value: 'x'"),
        (["frobnicate"], "loopcraft: error: argument command: invalid choice"),
    ],
)
def test_a_usage_error_is_one_line(capsys, argv, words):
    assert words in _refused(capsys, argv)


def test_an_error_path_names_the_files_keys_not_the_schemas_tags(capsys, lead):
    data = json.loads(lead.read_text())
    blocks = data["problem"]["conditions"][0]["plant"]["blocks"]
    for transfer, path in (
        ({"kind": "state_space", "A": [[1]], "B": [1], "C": [1], "D": 0, "bogus": 1}, "transfer.bogus: "),
        ({"kind": "expression", "expression": [True]}, "transfer.expression: "),
    ):
        blocks[-1]["transfer"] = transfer
        lead.write_text(json.dumps(data))
        err = _refused(capsys, ["report", str(lead)])
        assert f"problem.conditions[0].plant.blocks[1].{path}" in err and "state_space." not in err, err


def test_json_values_are_shown_as_json_and_exceptions_in_words():
    assert shown_json([True]) == "a list [true]" and shown_json(None) == "null"
    assert shown_json("x") == 'the string "x"' and shown_json({"a": 1.5}) == 'an object {"a": 1.5}'
    assert reason(ValueError("You must specify cores\n  cluster = LSFCluster(cores=8)")) == (
        "You must specify cores cluster = LSFCluster(cores=8)"
    )
    assert in_words(ZeroDivisionError()) == "zero division" and in_words(TimeoutError()) == "timeout"


def test_a_held_delay_points_at_delay(capsys):
    argv = ["analyze", "--variable", "z", "--sample-time", "0.1", "--tf", "1", "--held", "exp(-0.1*s)/(s+1)"]
    assert "give its delay exp(-T*s) as --delay T" in _refused(capsys, argv)


def test_a_loop_in_z_whose_gain_overflows_is_refused(capsys):
    argv = ["analyze", "--variable", "z", "--sample-time", "0.1", "--tf", "1e308*(z+1)/(z-0.5)"]
    assert "beyond double precision" in _refused(capsys, argv)


def test_a_long_name_is_echoed_cut_short(capsys, lead):
    for text in ("b" * 3000 + "=1", "compensator." + "z" * 3000 + "=2", "K" * 5000 + "*=2"):
        err = _refused(capsys, ["set", str(lead), text])
        assert len(err) < 400 and "characters" in err, err


def test_adopt_worst_naming_no_row_is_refused_before_any_sample_runs(capsys, lead, monkeypatch):
    import sessions.sweeps.jobs as jobs

    def ran(*args, **kwargs):
        raise AssertionError("the study ran")

    monkeypatch.setattr(jobs, "execute_serial", ran)
    argv = ["sweep", str(lead), "--tolerance", "K=+-10%", "--samples", "50", "--serial", "--adopt-worst"]
    err = _refused(capsys, [*argv, "NOSUCH"])
    assert "no measure row 'NOSUCH' in the tolerance study (rows: GM1@nominal, PM1@nominal" in err
    assert len(_refused(capsys, [*argv, "PM" * 2000])) < 600

"""Extreme but well-formed input to `set`, discretized blocks and sample times: one line,
exit status 2, the session untouched, never a traceback (issue 50's fuzz signatures: an
OverflowError in shaping.parse, math domain errors in compensator_moves.miss, pydantic's
dump of an infinite value, LinAlgError and OverflowError in discretize)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tui.cli import main


@pytest.fixture
def lead(tmp_path: Path) -> Path:
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s*(s+1))", "--compensator", "lead"]) == 0
    return path


def _refused(capsys, argv: list[str], words: str) -> None:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1 and "Error" not in err, err


@pytest.mark.parametrize(
    "assignment, words",
    [
        ("K*=+1e9dB", "+1e9 dB is out of range"),
        ("K*=-1e400dB", "the value must be finite"),
        ("compensator.zero1=-1", "-1 is no frequency"),
        ("compensator.pole1*=0", "0 is no frequency"),
        ("compensator.gain=0", "0 is no gain"),
    ],
)
def test_a_value_out_of_range_is_refused_naming_it(capsys, lead, assignment, words):
    before = lead.read_bytes()
    _refused(capsys, ["set", str(lead), assignment], words)
    assert lead.read_bytes() == before


def test_a_parameter_scaled_beyond_the_float_range_is_refused(capsys, lead):
    data = json.loads(lead.read_text())
    for p in data["problem"]["parameters"]:
        p.pop("min", None), p.pop("max", None)
    lead.write_text(json.dumps(data))
    before = lead.read_bytes()
    _refused(capsys, ["set", str(lead), "K*=1e308", "K*=1e308"], "K = inf: not a finite number")
    assert lead.read_bytes() == before


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--tf", "1", "--sample-time", "1e100", "--held", "1/(s+1)"], "cannot be computed in double precision"),
        (["--tf", "1", "--sample-time", "0.1", "--held", "1/(s+1e300)"], "fastest pole x T = 1e+299"),
        (["--tf", "1", "--sample-time", "5e-324", "--held", "1/(s+1)", "--delay", "0.1"], "delay / T = inf"),
    ],
)
def test_a_block_held_beyond_double_precision_is_refused(capsys, argv, words):
    _refused(capsys, ["analyze", "--variable", "z", *argv], words)


def test_a_sample_time_whose_nyquist_frequency_overflows_is_refused(capsys, tmp_path):
    for plant in ("exp(-0.1*s)/(s+1)", "1/(s+1)"):
        _refused(
            capsys,
            ["new", str(tmp_path / "d.json"), "--plant", plant, "--sample-time", "5e-324"],
            "its Nyquist frequency pi/T is beyond 1e306 rad/s",
        )
    assert not (tmp_path / "d.json").exists()

"""A time target's response is checked at load, naming its JSON path: its input and
output are signals of every condition it is evaluated in, a mean square has a PSD
(a mean_square target naming a signal the condition lacks raised ValueError from
tuple.index inside the run)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sessions.errors import SessionError
from sessions.store import load_session
from tui.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "coebra_launch_vehicle.json"


def _session(tmp_path: Path, measure: str, **response) -> Path:
    doc = json.loads(EXAMPLE.read_text())
    doc.update(records=[], current_iteration=0, state=None)
    target = doc["problem"]["targets"][5]
    target["measure"] = measure
    target["response"].update(psd="1/(s+1)" if measure == "mean_square" else None, **response)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("measure", ["mean_square", "peak_response"])
@pytest.mark.parametrize(
    ("response", "where"),
    [({"input": "nosuch"}, "response.input: 'nosuch' is not an input"), ({"output": "gone"}, "response.output")],
)
def test_a_response_naming_a_missing_signal_is_refused_at_load(tmp_path, measure, response, where, capsys):
    path = _session(tmp_path, measure, **response)
    with pytest.raises(SessionError, match=rf"problem\.targets\[5\]\.{where}.*condition 'switch-in'"):
        load_session(path)
    assert main(["run", str(path), "--out", str(tmp_path / "out.json")]) == 2
    assert "Traceback" not in capsys.readouterr().err


def test_a_mean_square_without_its_psd_is_refused_at_load(tmp_path):
    path = _session(tmp_path, "mean_square")
    doc = json.loads(path.read_text())
    doc["problem"]["targets"][5]["response"]["psd"] = None
    path.write_text(json.dumps(doc))
    with pytest.raises(SessionError, match=r"problem\.targets\[5\]\.response\.psd"):
        load_session(path)


def test_a_response_of_another_condition_is_checked_there_only(tmp_path):
    path = _session(tmp_path, "mean_square")
    load_session(path)  # the example's own signals load

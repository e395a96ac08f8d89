"""An export whose numbers overflow names what and where: the condition and entry
whose coefficients are not finite, or the JSON path of a non-finite number
(numpy's "array must not contain infs or NaNs" said neither)."""

from __future__ import annotations

import json

import pytest

from sessions.export.formats import first_non_finite
from tests.sessions.conftest import MATCHING
from tui.cli import main


def _session(tmp_path, expression: str):
    doc = json.loads(json.dumps(MATCHING))
    doc["problem"]["conditions"][0]["plant"]["blocks"][0]["transfer"]["expression"] = expression
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("to", ["python", "matlab", "json", "csv"])
def test_an_entry_whose_numbers_overflow_is_named(tmp_path, to, monkeypatch, capsys):
    import numpy as np

    from sessions.export import design_model

    def overflows(expression, values):
        raise np.linalg.LinAlgError("Array must not contain infs or NaNs")

    monkeypatch.setattr(design_model, "pole_zero", overflows)
    assert main(["export", str(_session(tmp_path, "K*(1+T*s)")), "--to", to]) == 2
    err = capsys.readouterr().err
    assert "condition 'nominal', C: cannot be exported: its numbers are not finite" in err
    assert "infs or NaNs" not in err


def test_a_non_finite_json_number_is_named_by_its_path(tmp_path, monkeypatch, capsys):
    from sessions.export import data

    monkeypatch.setattr(data, "design_json", lambda d, t=None: {"conditions": [{"gain": 1.0, "poles": [float("inf")]}]})
    assert main(["export", str(_session(tmp_path, "K*(1+T*s)")), "--to", "json"]) == 2
    err = capsys.readouterr().err
    assert "conditions[0].poles[0]: not finite" in err and "JSON compliant" not in err


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("expression", ["K*s*5e-324*(0-7.25*1e3*s)-1e-3", "-s/100/(s+1e308)"])
@pytest.mark.parametrize("to", ["python", "json", "csv"])
def test_fuzzed_overflows_export_or_say_where(tmp_path, expression, to, capsys):
    status = main(["export", str(_session(tmp_path, expression)), "--to", to, "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 0 or (status == 2 and ("condition 'nominal'" in err or "conditions[0]" in err)), err


def test_first_non_finite_finds_the_path():
    assert first_non_finite({"a": [1.0, {"b": float("nan")}]}, "") == "a[1].b"
    assert first_non_finite({"a": [1.0]}, "") is None

"""`sessions.new.templates.new_session`: every structure gives a session that loads,
with bounded positive time constants and gains, PM >= 45 deg and GM >= 6 dB."""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np
import pytest

from engine.loop.responses import open_loop
from sessions.errors import SessionError
from sessions.new.templates import STRUCTURES, new_session
from sessions.runner import run_session
from sessions.store import parse_session

PLANT = "16000/(s*(s+8)*(s+20))"


def _load(data: dict, folder: Path = Path(".")):
    return parse_session(json.dumps(data), "new.json", folder)


@pytest.mark.parametrize("algorithm", ["slp", "cip"])
@pytest.mark.parametrize("structure", list(STRUCTURES))
def test_every_structure_loads(structure, algorithm):
    session = _load(new_session(PLANT, structure, algorithm))
    problem = session.problem
    assert session.model.algorithm.name == algorithm
    (condition,) = problem.conditions
    assert condition.break_at == "e"
    for p in problem.parameters:
        assert p.sign == "positive" and p.lower() > 0 and np.isfinite(p.upper()) and p.lower() <= p.at(0) <= p.upper()
    targets = {(t.measure, t.bands[0].desired) for t in problem.targets}
    assert targets == {("phase_margin_deg", 45.0), ("gain_margin_db", 6.0)}


def test_the_loop_is_unity_feedback_of_compensator_and_plant():
    """lead K (1 + T1 s)/(1 + T2 s) at K = 1, T1 = 1, T2 = 0.1, against python-control."""
    session = _load(new_session(PLANT, "lead"))
    condition = session.problem.conditions[0]
    w = np.array([0.5, 5.0, 50.0])
    gh = open_loop(condition.network, "e", w, session.problem.condition_values(0), sensitivities=False).value
    reference = control.tf([1.0, 1.0], [0.1, 1.0]) * control.tf([16000.0], [1.0, 28.0, 160.0, 0.0])
    assert np.allclose(gh, reference(1j * w), rtol=1e-13)


def test_a_run_improves_the_lead_lag_design():
    session = _load(new_session(PLANT, "lead-lag"))
    records = run_session(session, iterations=20, autosave=False)
    assert all(m.satisfied for m in records[-1].measures)


def test_custom_expression_delay_and_w_plane():
    data = new_session("exp(-0.1*s)/(s+1)", "Kp*(1+Ta*s)/(1+b)")
    blocks = data["problem"]["conditions"][0]["plant"]["blocks"]
    assert blocks[-1]["transfer"] == {"kind": "delay", "tau": 0.1}
    names = {p["name"]: p for p in data["problem"]["parameters"]}
    assert set(names) == {"Kp", "Ta", "b"} and names["Ta"]["min"] > 0 and names["b"]["min"] < 0
    _load(data)
    w = new_session("0.77*(1-w)/(w*(1+w))", "lag")
    assert w["problem"]["conditions"][0]["variable"] == "w"
    assert "w" in w["problem"]["conditions"][0]["plant"]["blocks"][0]["transfer"]["expression"]
    _load(w)


@pytest.mark.parametrize(
    "plant, compensator, algorithm, message",
    [
        ("1/(s+a)", "lead", "slp", "--plant: '1/(s+a)' names a"),
        ("1/(s+", "lead", "slp", "--plant:"),
        ("1/(s+1)", "s+1", "slp", "--compensator: 's+1' has no parameter"),
        ("1/(s+1)", "lead", "qcg", "algorithm 'qcg'"),
    ],
)
def test_bad_input_names_what_is_wrong(plant, compensator, algorithm, message):
    with pytest.raises(SessionError, match=None) as caught:
        new_session(plant, compensator, algorithm)
    assert message in str(caught.value)

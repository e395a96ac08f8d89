"""A design stuck at a bound, or amplifying noise, says so (issue 37 section 2): the lead
for 1/(s^2 (s+10)) with its pole time constant at the lower bound 1e-4."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.design.notes import at_bounds, noise_notes
from engine.design.problem import Condition, Grid, Parameter, Problem
from sessions.new.templates import new_session
from tui.cli import main


def lead_problem(K: float, T1: float, T2: float) -> Problem:
    network = unity_feedback(["K*(1+T1*s)/(1+T2*s)", "1/(s^2*(s+10))"])
    parameters = (
        Parameter("K", K, 1e-6, 1e6, sign="positive"),
        Parameter("T1", T1, 1e-4, 1e4, sign="positive"),
        Parameter("T2", T2, 1e-4, 1e4, sign="positive"),
    )
    return Problem((Condition("nominal", network, "e"),), parameters, (), Grid(np.geomspace(1e-3, 1e3, 400)))


def test_a_parameter_at_its_bound_is_named_with_the_bound():
    p = lead_problem(13.5, 1.0, 1e-4)
    assert at_bounds(p, p.named()) == ["T2 at its lower bound 0.0001"]
    assert at_bounds(p, p.named() | {"T2": 0.02}) == []


def test_a_compensator_amplifying_noise_is_flagged_against_an_independent_computation():
    p = lead_problem(13.5, 1.0, 1e-4)
    (note,) = noise_notes(p, p.named())
    # independently: |K(j inf)| = K T1/T2; |K(j wc)| at the loop's gain crossover, found densely
    w = np.geomspace(1e-2, 1e2, 200001)
    compensator = 13.5 * (1 + 1j * w) / (1 + 1e-4j * w)
    loop = compensator / ((1j * w) ** 2 * (1j * w + 10))
    wc = w[np.argmin(np.abs(np.abs(loop) - 1))]
    ratio = 13.5 * 1.0 / 1e-4 / abs(13.5 * (1 + 1j * wc) / (1 + 1e-4j * wc))
    shown = float(note.split("gain is ")[1].split(" times")[0])
    assert shown == pytest.approx(ratio, rel=1e-2) and ratio > p.noise_factor == 100.0
    assert noise_notes(p, p.named() | {"T2": 0.1}) == []  # a lead of ratio 10: quiet
    assert noise_notes(replace(p, noise_factor=ratio * 1.01), p.named()) == []  # the problem's own factor
    assert noise_notes(replace(p, noise_factor=ratio * 0.99), p.named())


def test_the_session_sets_the_noise_factor(tmp_path, capsys):
    data = new_session("1/(s^2*(s+10))", "lead")
    for parameter in data["problem"]["parameters"]:
        parameter["value"] = {"K": 13.5, "T1": 1.0, "T2": 1e-4}[parameter["name"]]
    data["problem"]["constraints"] = []
    data["problem"]["noise_factor"] = 1e4  # the ratio is 5.35e3: below it, quiet
    path = tmp_path / "lead.json"
    path.write_text(json.dumps(data))
    assert main(["report", str(path)]) == 0
    assert "amplifies sensor noise" not in capsys.readouterr().out
    data["problem"]["noise_factor"] = 0.5
    path.write_text(json.dumps(data))
    assert main(["report", str(path)]) == 2
    assert "problem.noise_factor" in capsys.readouterr().err


def test_run_and_report_list_the_notes(tmp_path, capsys):
    data = new_session("1/(s^2*(s+10))", "lead")
    for parameter in data["problem"]["parameters"]:
        parameter["value"] = {"K": 13.5, "T1": 1.0, "T2": 1e-4}[parameter["name"]]
    data["problem"]["constraints"] = []
    path = tmp_path / "lead.json"
    path.write_text(json.dumps(data))
    assert main(["report", str(path)]) == 0
    out = capsys.readouterr().out
    assert "note: T2 at its lower bound 0.0001" in out and "amplifies sensor noise" in out
    assert main(["report", str(path), "--format", "json"]) == 0
    assert "T2 at its lower bound 0.0001" in json.loads(capsys.readouterr().out)["design_notes"]


def test_a_new_lead_or_lag_carries_its_ratio_limits_as_constraints():
    for structure in ("lead", "lag"):
        assert new_session("1/(s*(s+1))", structure)["problem"]["constraints"] == ["T1 <= 20*T2", "T2 <= 20*T1"]
    assert "constraints" not in new_session("1/(s*(s+1))", "pi")["problem"]

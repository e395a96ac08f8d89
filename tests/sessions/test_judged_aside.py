"""Refusals as choices (issue 51, section 3): an algorithm that cannot read a target runs on the
ones it can; the others are judged at every iteration's design and shown in its tableau, named
in its stop, and switching algorithm back and forth never empties the tableau.  The judged
crossover is checked against numpy: the lead's loop sampled densely, |L| = 1 refined."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sessions.new.templates import new_session
from sessions.runner import replay, run_session
from sessions.store import parse_session
from sessions.target_use import unusable_targets
from tui.state.workbench import Workbench


def lead_session(algorithm: str):
    data = new_session("1/(s*(s+1))", "lead", algorithm)
    data["problem"]["targets"].append({"measure": "crossover_frequency", "bands": [{"desired": 1.0}]})
    return parse_session(json.dumps(data), "test", Path("."))


def reference_crossover(values: dict) -> float:
    w = np.geomspace(1e-2, 1e2, 200001)
    s = 1j * w
    loop = values["K"] * (1 + values["T1"] * s) / (1 + values["T2"] * s) / (s * (s + 1))
    above = np.abs(loop) >= 1
    i = np.flatnonzero(above[:-1] != above[1:])[-1]
    return float(w[i])


def test_cip_runs_on_the_margins_and_judges_the_crossover():
    session = lead_session("cip")
    run = run_session(session, until_done=True, autosave=False)
    assert run and run[-1].status.finished
    for record in run:
        judged = [row for row in record.measures if row.kind == "crossover_frequency"]
        assert len(judged) == 1 and judged[0].method == "judged only: cip does not read it"
        design = {k: float(v) for k, v in record.parameters.items()}
        assert judged[0].value == pytest.approx(reference_crossover(design), rel=1e-4)
        assert judged[0].satisfied == (judged[0].value >= 1.0)
    assert "judged only (cip does not read them): WC1" in run[-1].reason
    assert replay(session).ok


def test_switching_algorithm_keeps_the_tableau():
    bench = Workbench(lead_session("slp"))
    for name in ("cip", "slp", "cip"):
        bench.set_algorithm(name)
        rows = bench.initial_record().measures
        kinds = [row.kind for row in rows]
        assert "phase_margin_deg" in kinds and "crossover_frequency" in kinds
        assert bench.step() is not None


def test_the_picker_says_which_targets_are_judged_only():
    lines = unusable_targets(["phase_margin_deg", "crossover_frequency"], "cip")
    assert len(lines) == 1 and lines[0].startswith("crossover_frequency: judged only: cip does not read it")

"""The report's figures draw each requirement where the curve and the target are: a phase margin's
marks and requirement on the curve's own 360 deg branch (numpy's unwrap of the plotted GH), each
gain-margin row at its own level with its sense, each modal-peak band's ceiling over that band only
(the session's targets), the margins on the Nichols chart; and no matplotlib warning on stderr."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from engine.stepping.driver import first_record
from sessions.lifecycle import registration, stepper
from sessions.report import figures
from sessions.report.content import _curve
from sessions.store import load_session
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "sessions" / "examples"


@pytest.fixture(scope="module")
def launch_vehicle():
    """The launch vehicle's switch-in condition: its curve (margins marked) and its initial rows."""
    session = load_session(EXAMPLES / "coebra_launch_vehicle.json")
    curve = _curve(session, 0, None, "initial", "current", True)
    record = first_record(registration(session).presenter, stepper(session))
    rows = [r for r in record.measures if r.condition == session.problem.conditions[0].name]
    return session, curve, rows


def _plotted_phase(curve, frequency: float) -> float:
    phase = np.degrees(np.unwrap(np.angle(curve.gh)))
    return float(np.interp(np.log(frequency), np.log(curve.omega), phase))


def test_phase_margins_are_marked_on_the_curve_s_branch(launch_vehicle):
    """The curve stands near +188 deg at the 0.94 rad/s crossover: the PM >= 30 requirement is drawn at
    +210 deg (-150 + 360), not at -150."""
    _, curve, rows = launch_vehicle
    (pm,) = [r for r in rows if r.kind == "phase_margin_deg" and r.desired is not None]
    there = _plotted_phase(curve, pm.frequency)
    assert there > 180  # the case of the issue: another branch than -180
    drawn = [q for q in figures.bode_requirements(curve, rows) if q.panel == "phase"]
    assert len(drawn) == 1 and drawn[0].y[0] == pytest.approx(-180 + pm.desired + 360)
    assert abs(drawn[0].y[0] - there) < 180 and drawn[0].x[0] < pm.frequency < drawn[0].x[1]
    for margin in curve.margins.phase:  # the mark: arg GH there, on the same branch
        mark = curve.on_branch(float(np.degrees(np.angle(margin.gh))), margin.frequency)
        assert mark == pytest.approx(_plotted_phase(curve, margin.frequency), abs=1.0)


def test_each_gain_margin_row_and_modal_peak_band_is_drawn_as_judged(launch_vehicle):
    session, curve, rows = launch_vehicle
    targets = session.problem.targets
    drawn = figures.bode_requirements(curve, rows, targets)
    judged = [r for r in rows if r.kind == "gain_margin_db" and r.desired is not None and r.frequency]
    for row in judged:
        (line,) = [q for q in drawn if q.label.startswith(f"{row.name} ")]
        sense = ">=" if row.at_least else "<="
        assert line.y == (-row.desired, -row.desired) and f"{sense} {row.desired:g} dB" in line.label
        assert line.x[0] < row.frequency < line.x[1] and line.met == row.satisfied
    bands = [
        b
        for t in json.loads((EXAMPLES / "coebra_launch_vehicle.json").read_text())["problem"]["targets"]
        if t["measure"] == "modal_peak_db"
        for b in t["bands"]
    ]
    peaks = [q for q in drawn if " dB in " in q.label]
    assert [(q.x[0], q.x[1]) for q in peaks] == [(b["low"], b["high"]) for b in bands]  # each in its band
    assert [q.y[0] for q in peaks] == [b["required"] for b in bands]  # the level the rows are judged on


def test_the_nichols_chart_carries_the_margins_requirements(launch_vehicle):
    _, curve, rows = launch_vehicle
    drawn = figures.nichols_requirements(curve, rows)
    (pm,) = [r for r in rows if r.kind == "phase_margin_deg" and r.desired is not None]
    (line,) = [q for q in drawn if q.label.startswith(pm.name)]
    assert line.x[0] == pytest.approx(-180 + pm.desired + 360) and line.y[0] < 0 < line.y[1]
    assert any(q.label.startswith("GM") for q in drawn)


def test_reporting_a_loop_in_z_warns_nothing(tmp_path, capsys):
    """coebra_kuo_z's root locus about the unit circle printed matplotlib's "Ignoring fixed x limits to
    fulfill fixed data aspect" twice."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["report", str(EXAMPLES / "coebra_kuo_z.json"), "--format", "html", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().err == ""

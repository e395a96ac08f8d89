"""The app's kinds of new session: each loads, and the matrix form and the two
loops measure what the diagram they stand for measures."""

from __future__ import annotations

import json
import math

import control as ct
import pytest

from engine.design.tableau import tableau
from sessions.errors import SessionError
from sessions.new.template_kinds import dae_session, in_unit, matrix_session, table_session, two_loop_session
from sessions.new.templates import new_session
from sessions.store import parse_session


def _load(data, tmp_path):
    return parse_session(json.dumps(data), str(tmp_path / "new.json"), tmp_path)


def _values(session):
    return {r.name: r.value for r in tableau(session.problem)}


def test_the_matrix_form_measures_what_the_diagram_measures(tmp_path):
    plant = "10/(s*(s+1)*(s+5))"
    diagram, matrix = (_load(f(plant, "lead"), tmp_path) for f in (new_session, matrix_session))
    a, b = _values(diagram), _values(matrix)
    assert a.keys() == b.keys() and all(math.isclose(a[k], b[k], rel_tol=1e-9) for k in a)
    with pytest.raises(SessionError, match="delay"):
        matrix_session("exp(-0.1*s)/(s+1)")


def test_two_loops_have_the_margins_at_each_break_point_with_the_other_loop_closed(tmp_path):
    session = _load(two_loop_session("10/(s+1)", "1/s", "pi", "lead"), tmp_path)
    values = session.problem.named()
    v = {k: (x[0] if isinstance(x, list) else x) for k, x in values.items()}
    s = ct.tf("s")
    inner_c = v["K_i"] * (1 + v["Ti_i"] * s) / (v["Ti_i"] * s)
    outer_c = v["K_o"] * (1 + v["T1_o"] * s) / (1 + v["T2_o"] * s)
    inner_loop = inner_c * 10 / (s + 1)
    outer_loop = outer_c * ct.feedback(inner_loop, 1) * (1 / s)
    at_e2 = inner_c * 10 / (s + 1) * (1 + outer_c / s)  # e2 = x_ref - x with x_ref = -C_o G2 x
    rows = {(r.condition, r.kind): r.value for r in tableau(session.problem)}
    for condition, loop in (("outer loop", outer_loop), ("inner loop", at_e2)):
        _, pm, _, _ = ct.margin(loop)
        assert math.isclose(rows[(condition, "phase_margin_deg")], pm, rel_tol=1e-6), condition


def test_a_table_the_projection_and_the_unit(tmp_path):
    (tmp_path / "plant.csv").write_text("hz,mag,deg\n0.1,10,-90\n1,1,-120\n10,0.1,-170\n")
    table = {
        "kind": "table",
        "table": {"csv": "plant.csv", "columns": ["hz", "mag", "deg"], "form": "polar", "unit": "hz", "gain": 1.0},
    }
    session = _load(table_session(table, [0.1, 1, 10]), tmp_path)
    assert session.model.problem.grid.unit == "hz" and session.model.problem.grid.stop == 10
    assert _load(dae_session(), tmp_path).model.algorithm.name == "projection"
    hz = in_unit(new_session("1/(s+1)"), "hz")["problem"]["grid"]
    rad = new_session("1/(s+1)")["problem"]["grid"]
    assert hz["unit"] == "hz" and math.isclose(hz["start"] * 2 * math.pi, rad["start"])

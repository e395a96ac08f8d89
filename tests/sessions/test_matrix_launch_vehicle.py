"""The launch vehicle in COEBRA's matrix format (coebra_launch_vehicle_matrix.json,
report 003 Appendix D) is the diagram session's problem: the same model but its
plant, every entry at most a second-order ratio in s (which the build does not
check: it takes entries of any order), A(s) x = B alpha_w solved here with numpy
gives the engine's loop, and the loops, measures and slp iterations equal the
block-diagram session's."""

from __future__ import annotations

import ast
import dataclasses
import json
import shutil
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

from engine.design.tableau import TABLEAU_MEASURES, tableau
from engine.loop.responses import closed_loop, open_loop
from engine.slp.measures import evaluate, measure_specs
from sessions.runner import run_session
from sessions.store import load_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
MATRIX, DIAGRAM = "coebra_launch_vehicle_matrix.json", "coebra_launch_vehicle.json"
REL = 1e-9


@pytest.fixture(scope="module")
def sessions():
    return load_session(EXAMPLES / MATRIX), load_session(EXAMPLES / DIAGRAM)


def _degrees(node: ast.AST) -> tuple[int, int]:
    """Upper bounds on the degrees in s of the numerator and denominator of an expression
    (exact for the sums of monomials and their products and quotients the example writes)."""
    if isinstance(node, ast.Expression):
        return _degrees(node.body)
    if isinstance(node, ast.Constant):
        return 0, 0
    if isinstance(node, ast.Name):
        return (1, 0) if node.id == "s" else (0, 0)
    if isinstance(node, ast.UnaryOp):
        return _degrees(node.operand)
    assert isinstance(node, ast.BinOp), ast.dump(node)
    (n1, d1), (n2, d2) = _degrees(node.left), _degrees(node.right)
    if isinstance(node.op, (ast.Add, ast.Sub)):
        return max(n1 + d2, n2 + d1), d1 + d2
    if isinstance(node.op, ast.Mult):
        return n1 + n2, d1 + d2
    if isinstance(node.op, ast.Div):
        return n1 + d2, d1 + n2
    assert isinstance(node.op, ast.Pow) and isinstance(node.right, ast.Constant)
    k = node.right.value
    return (k * n1, k * d1) if k >= 0 else (-k * d1, -k * n1)


def _value(node: ast.AST, s: np.ndarray, params: Mapping[str, float]) -> np.ndarray:
    """The expression at the complex frequencies ``s`` (numbers, names, + - * / and powers)."""
    if isinstance(node, ast.Expression):
        return _value(node.body, s, params)
    if isinstance(node, ast.Constant):
        return np.full_like(s, node.value)
    if isinstance(node, ast.Name):
        return s if node.id == "s" else np.full_like(s, params[node.id])
    if isinstance(node, ast.UnaryOp):
        return -_value(node.operand, s, params) if isinstance(node.op, ast.USub) else _value(node.operand, s, params)
    left, right = _value(node.left, s, params), _value(node.right, s, params)
    op = type(node.op)
    if op is ast.Pow:
        return left**node.right.value
    return {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.divide}[op](left, right)


def _parse(text: str) -> ast.Expression:
    """An entry as Python reads it: the format's ``^`` is ``**`` (in Python it binds looser than +)."""
    return ast.parse(text.replace("^", "**"), mode="eval")


def test_example_is_generated_by_its_script(tmp_path):
    from sessions.examples.coebra_launch_vehicle_matrix import write_example

    write_example(tmp_path)
    assert json.loads((tmp_path / MATRIX).read_text()) == json.loads((EXAMPLES / MATRIX).read_text())


def test_everything_but_the_plants_is_the_diagram_sessions(sessions):
    matrix, diagram = (s.model for s in sessions)
    assert matrix.algorithm == diagram.algorithm and matrix.algorithm.name == "slp"
    for field in ("grid", "parameters", "targets", "equalities", "objective"):
        assert getattr(matrix.problem, field) == getattr(diagram.problem, field), field
    assert len(matrix.problem.conditions) == len(diagram.problem.conditions) == 3
    for m, d in zip(matrix.problem.conditions, diagram.problem.conditions):
        assert (m.name, m.variable, m.break_at) == (d.name, d.variable, d.break_at)
        assert m.plant.format == "matrix" and d.plant.format == "diagram"
        assert m.plant.input_name == d.plant.inputs[0] == "alpha_w"
    assert "Figure D-1" in matrix.notes and "slack variable" in matrix.notes


def test_every_entry_is_at_most_a_second_order_ratio_in_s(sessions):
    """Appendix D: each element at most a second-order polynomial ratio in s, one forcing
    function; Figure D-1's rows: a_11 = 1 with b_1 = 1, a_ii = -1 elsewhere."""
    for condition in sessions[0].model.problem.conditions:
        plant = condition.plant
        cells = [(e.row, e.col) for e in plant.entries]
        assert len(set(cells)) == len(cells)
        for e in plant.entries:
            num, den = _degrees(_parse(e.expression))
            assert num <= 2 and den <= 2, (e.row, e.col, e.expression)
        diagonal = {e.row: e.expression for e in plant.entries if e.row == e.col}
        assert diagonal == {i: "1" if i == 1 else "-1" for i in range(1, len(plant.signals) + 1)}
        assert (plant.forcing_row, plant.forcing) == (1, "1")
        # why the slack variables: the attitude sensor's delta entry, the sum of its modes, is of sixth order
        delta = plant.signals.index("delta") + 1
        modes = [
            e.expression
            for e in plant.entries
            if e.col == delta and plant.signals[e.row - 1] in ("q1_att", "q2_att", "q3_att")
        ]
        assert len(modes) == 3 and _degrees(_parse("+".join(f"({m})" for m in modes))) == (4, 6)


def test_open_loop_is_that_of_a_of_s_x_equals_b_theta(sessions):
    """GH at dc from A(j omega) x = B alpha_w solved with numpy (a unit in place of every use
    of dc, GH = -dc) equals the engine's loop of the matrix session."""
    problem, model = sessions[0].problem, sessions[0].model
    s = 1j * problem.grid.omega
    for c, condition in enumerate(model.problem.conditions):
        plant, params = condition.plant, problem.condition_values(c)
        n, k = len(plant.signals), plant.signals.index("dc")
        A = np.zeros((s.size, n, n), dtype=complex)
        for e in plant.entries:
            A[:, e.row - 1, e.col - 1] = _value(_parse(e.expression), s, params)
        rhs = -A[:, :, k].copy()
        rhs[:, k] = 0.0
        M = A.copy()
        M[:, :, k] = 0.0
        M[:, k, k] = A[:, k, k]
        x = np.linalg.solve(M, rhs[:, :, None])[:, :, 0]
        gh = open_loop(problem.conditions[c].network, "dc", problem.grid.omega, params).value
        np.testing.assert_allclose(gh, -x[:, k], rtol=REL, atol=0)


def test_open_and_closed_loops_agree_on_the_grid(sessions):
    (pm, pd), omega = (s.problem for s in sessions), sessions[1].problem.grid.omega
    for c in range(len(pd.conditions)):
        a = open_loop(pm.conditions[c].network, "dc", omega, pm.condition_values(c))
        b = open_loop(pd.conditions[c].network, "dc", omega, pd.condition_values(c))
        np.testing.assert_allclose(a.value, b.value, rtol=REL, atol=0)
        order = [b.parameters.index(p) for p in a.parameters]
        assert sorted(a.parameters) == sorted(b.parameters)
        scale = np.max(np.abs(b.sensitivity), axis=0)[order]
        np.testing.assert_allclose(a.sensitivity / scale, b.sensitivity[:, order] / scale, rtol=0, atol=REL)
        wind = [
            closed_loop(
                p.conditions[c].network, "alpha_w", "alpha", omega, p.condition_values(c), sensitivities=False
            ).value
            for p in (pm, pd)
        ]
        np.testing.assert_allclose(wind[0], wind[1], rtol=REL, atol=0)


def test_tableau_and_slp_measures_agree_at_every_condition(sessions):
    """The generic tableau (the targets it evaluates) and slp's rows (every target, with
    the modal peaks, the wind's peak angle of attack and stability) at the start."""
    (pm, pd) = (s.problem for s in sessions)
    rows = []
    for p in (pm, pd):
        margins_only = dataclasses.replace(p, targets=tuple(t for t in p.targets if t.measure in TABLEAU_MEASURES))
        rows.append(tableau(margins_only))
    assert [(r.name, r.kind, r.condition, r.satisfied) for r in rows[0]] == [
        (r.name, r.kind, r.condition, r.satisfied) for r in rows[1]
    ]
    assert {r.condition for r in rows[1]} == {"switch-in", "max-q", "switch-out"}
    for a, b in zip(*rows):
        assert a.value == pytest.approx(b.value, rel=REL) and a.frequency == pytest.approx(b.frequency, rel=REL)
    specs = measure_specs(pd)
    assert [(s.name, s.kind, s.condition) for s in measure_specs(pm)] == [(s.name, s.kind, s.condition) for s in specs]
    assert {"peak_response", "modal_peak_db", "stability_abscissa"} <= {s.kind for s in specs}
    (vm, fm), (vd, fd) = evaluate(pm, pm.vector(), specs), evaluate(pd, pd.vector(), specs)
    # no gain margin in 1..8 rad/s at the start, per condition: an infinite one there (absent), at no frequency
    assert np.count_nonzero(np.isposinf(vd) & np.isnan(fd)) == 3 and not np.any(np.isnan(vd))
    np.testing.assert_allclose(vm, vd, rtol=REL, atol=0)
    np.testing.assert_allclose(fm, fd, rtol=REL, atol=0)


def test_slp_makes_the_same_three_iterations(tmp_path):
    runs = []
    for name in (MATRIX, DIAGRAM):
        shutil.copy(EXAMPLES / name, tmp_path / name)
        session = load_session(tmp_path / name)
        runs.append((session.problem, run_session(session, iterations=3, autosave=False)))
    (pm, matrix), (pd, diagram) = runs
    assert len(matrix) == len(diagram) == 3
    start = pd.vector()
    for a, b in zip(matrix, diagram):
        assert (a.iteration, a.status, a.reason) == (b.iteration, b.status, b.reason)
        xa, xb = pm.vector_from(a.parameters), pd.vector_from(b.parameters)
        np.testing.assert_allclose(xa, xb, rtol=1e-8, atol=0)
        assert a.objective == pytest.approx(b.objective, rel=1e-8)
    assert np.max(np.abs(xb - start) / np.abs(start)) > 0.1  # the iterations moved the design

"""Linear inequality constraints between parameters (issue 19): the reader, the rows
over the free vector, the projection, and slp, cip and qcg holding them."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog, minimize

from engine.design.constraint_reader import LinearFormError, read_constraint
from engine.design.constraints import LinearInequality, inequality_rows, project
from engine.design.problem import Parameter
from engine.errors import EngineError
from engine.qcg.setup import cascade_problem
from engine.slp.lp import solve_step
from sessions.lifecycle import adopt_parameters
from sessions.runner import replay, run_session
from sessions.store import load_session, save_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
T2_MIN = 0.01


@pytest.mark.parametrize(
    "text, terms, bound",
    [
        ("T1 >= 4*T2", {"T1": -1.0, "T2": 4.0}, 0.0),
        ("K + 2*T1 <= 10", {"K": 1.0, "T1": 2.0}, 10.0),
        ("0.1*3*T1 <= 2^-2", {"T1": 0.3}, 0.25),
        ("-(T1 - 2*(T2 + 1))/4 >= -1", {"T1": 0.25, "T2": -0.5}, 1.5),
        ("T1/10 + 1e-3 <= T2 * 2**0", {"T1": 0.1, "T2": -1.0}, -0.001),
        ("KD[max-q] - KD[0] <= 0.5", {"KD[max-q]": 1.0, "KD[0]": -1.0}, 0.5),
    ],
)
def test_accepted_forms(text, terms, bound):
    form = read_constraint(text)
    assert {str(ref): c for ref, c in form.terms} == terms
    assert form.bound == bound


@pytest.mark.parametrize(
    "text, column, words",
    [
        ("K*T1 <= 10", 2, "product of parameters"),
        ("1/T2 >= 3", 2, "division by parameter"),
        ("T1^2 <= 3", 3, "power of parameter"),
        ("T1 > 4*T2", 4, "strict"),
        ("T1 = 4*T2", 4, "equalities"),
        ("T1 >= 4T2", 8, "missing operator"),
        ("T1 >= 4*T2 >= 1", 12, "one comparison"),
        ("T1 - T1 <= 3", 9, "no parameter left"),
        ("T1 # 3", 4, "unexpected character"),
        ("T1 <= (2", 9, "')' is missing"),
        ("T1 <= 2/0", 8, "division by zero"),
        ("T1 <= 1e5000", 7, "beyond floating point"),
        ("T1 + 2", 7, "no comparison"),
    ],
)
def test_errors_give_the_column(text, column, words):
    with pytest.raises(LinearFormError) as caught:
        read_constraint(text)
    assert caught.value.position == column - 1
    assert f"column {column}" in str(caught.value) and words in str(caught.value)


def test_bounded_input():
    with pytest.raises(LinearFormError, match="at most 1000 characters"):
        read_constraint("T1 + " * 300 + "0 <= 1")
    with pytest.raises(LinearFormError, match="nested more than"):
        read_constraint("(" * 60 + "T1" + ")" * 60 + " <= 1")
    with pytest.raises(LinearFormError, match="beyond floating point"):
        read_constraint("((10^64)^64)^64 * T1 <= 1")


def test_projection_is_the_least_change():
    """Against scipy's SLSQP on the same least-distance problem."""
    A = np.array([[-1.0, 4.0, 0.0], [1.0, 1.0, 1.0]])
    b = np.array([0.0, 2.0])
    lower, upper = np.array([0.0, 0.01, -1.0]), np.array([5.0, 5.0, 1.0])
    z = np.array([0.3, 0.2, 0.9])
    x = project(z, A, b, lower, upper)
    reference = minimize(
        lambda y: np.sum((y - z) ** 2),
        z,
        jac=lambda y: 2 * (y - z),
        method="SLSQP",
        bounds=list(zip(lower, upper)),
        options={"ftol": 1e-15, "maxiter": 500},
        constraints=[{"type": "ineq", "fun": lambda y: b - A @ y, "jac": lambda y: -A}],
    )
    assert np.allclose(x, reference.x, atol=1e-7)
    assert np.all(A @ x - b <= 1e-12)
    assert np.array_equal(project(np.array([1.0, 0.1, 0.5]), A, b, lower, upper), [1.0, 0.1, 0.5])


def test_infeasible_projection_is_refused():
    with pytest.raises(EngineError, match="cannot be met"):
        project(np.zeros(1), np.array([[1.0]]), np.array([-1.0]), np.zeros(1), np.ones(1))


# -- the lead compensator (issue 19) ------------------------------------------


def lead_session(algorithm: str, start: tuple[float, float, float], constraints: list[str]) -> dict:
    """10/(s(s+1)(s+5)) with K(1 + T1 s)/(1 + T2 s): PM >= 50 deg, GM >= 10 dB."""
    blocks = [
        {
            "name": "lead",
            "input": "e",
            "output": "u",
            "transfer": {"kind": "expression", "expression": "K*(1 + T1*s)/(1 + T2*s)"},
        },
        {
            "name": "plant",
            "input": "u",
            "output": "y",
            "transfer": {"kind": "expression", "expression": "10/(s*(s + 1)*(s + 5))"},
        },
    ]
    problem = {
        "grid": {"start": 0.01, "stop": 100.0, "points": 300},
        "conditions": [
            {
                "name": "nominal",
                "break_at": "e",
                "plant": {
                    "format": "diagram",
                    "inputs": ["r"],
                    "blocks": blocks,
                    "junctions": [{"name": "sum", "output": "e", "plus": ["r"], "minus": ["y"]}],
                },
            }
        ],
        "parameters": [
            {"name": "K", "value": start[0], "min": 0.1, "max": 100.0},
            {"name": "T1", "value": start[1], "min": 0.01, "max": 100.0},
            {"name": "T2", "value": start[2], "min": T2_MIN, "max": 100.0},
        ],
        "targets": [
            {"measure": "phase_margin_deg", "bands": [{"desired": 50.0}]},
            {"measure": "gain_margin_db", "bands": [{"desired": 10.0}]},
        ],
        "constraints": constraints,
    }
    stamp = "2026-01-01T00:00:00+00:00"
    return {
        "schema_version": 2,
        "provenance": {"loopcraft_version": "0.1.0", "created": stamp, "modified": stamp},
        "problem": problem,
        "algorithm": {"name": algorithm, "settings": {}},
    }


def margins(K: float, T1: float, T2: float) -> tuple[float, float]:
    """PM (deg) and GM (dB) of 10 K (1 + T1 s)/(s (s+1)(s+5)(1 + T2 s)) in closed form: the phase
    is a sum of arctangents, each crossing found by bisection from a dense scan."""

    def magnitude(w):
        return 10 * K * np.hypot(1, T1 * w) / (w * np.hypot(1, w) * np.hypot(5, w) * np.hypot(1, T2 * w))

    def phase(w):
        return np.arctan(T1 * w) - np.pi / 2 - np.arctan(w) - np.arctan(w / 5) - np.arctan(T2 * w)

    w = np.geomspace(1e-3, 1e3, 200_001)
    crossover = _bisect(lambda v: magnitude(v) - 1.0, w)
    phase_cross = _bisect(lambda v: phase(v) + np.pi, w)
    return 180.0 + np.degrees(phase(crossover)), -20 * np.log10(magnitude(phase_cross))


def _bisect(f, w):
    """The first sign change of f on the scan w, to rounding."""
    values = f(w)
    k = int(np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))[0])
    lo, hi = w[k], w[k + 1]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.sign(f(mid)) == np.sign(f(lo)) else (lo, mid)
    return 0.5 * (lo + hi)


def _run(tmp_path: Path, doc: dict, name: str):
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(doc))
    session = load_session(path)
    run_session(session, until_done=True, autosave=False)
    save_session(session)
    again = load_session(path)
    result = replay(again)
    assert result.ok, result.message
    return session.model.records


@pytest.mark.parametrize("algorithm", ["slp", "cip"])
def test_lead_with_a_lower_ratio(tmp_path, algorithm):
    """T1 >= 4*T2 from its boundary: met at the end, T2 above its bound, PM and GM met."""
    records = _run(tmp_path, lead_session(algorithm, (2.0, 2.0, 0.5), ["T1 >= 4*T2"]), algorithm)
    final = records[-1]
    assert final["status"] == "converged"
    p = final["parameters"]
    assert p["T1"] - 4 * p["T2"] >= -1e-9
    assert p["T2"] > 2 * T2_MIN
    pm, gm = margins(p["K"], p["T1"], p["T2"])
    assert pm >= 50.0 - 1e-6 and gm >= 10.0 - 1e-6
    for record in records:  # every iterate meets it
        q = record["parameters"]
        assert q["T1"] - 4 * q["T2"] >= -1e-9


def test_cip_drives_t2_to_its_bound_without_a_ratio_cap(tmp_path):
    """The issue: from (1, 0.3, 0.05) cip ends with T2 at its lower bound (effectively PD)..."""
    records = _run(tmp_path, lead_session("cip", (1.0, 0.3, 0.05), []), "free")
    assert records[-1]["status"] == "converged"
    assert records[-1]["parameters"]["T2"] == pytest.approx(T2_MIN, abs=1e-12)


@pytest.mark.parametrize("algorithm", ["slp", "cip"])
def test_lead_with_a_ratio_cap(tmp_path, algorithm):
    """...and with T1 <= 10*T2 (lead ratio at most 10) both end on the cap, T2 well above it."""
    records = _run(tmp_path, lead_session(algorithm, (1.0, 0.3, 0.05), ["T1 <= 10*T2"]), algorithm)
    final = records[-1]
    assert final["status"] == "converged"
    p = final["parameters"]
    assert p["T1"] - 10 * p["T2"] <= 1e-9
    assert p["T1"] - 10 * p["T2"] >= -1e-6 * p["T1"]  # the cap is what holds T2 up
    assert p["T2"] > 3 * T2_MIN
    pm, gm = margins(p["K"], p["T1"], p["T2"])
    assert pm >= 50.0 - 1e-6 and gm >= 10.0 - 1e-6
    if algorithm == "cip":  # its direction held the cap (the report's hold, on a linear row)
        assert any("T1 <= 10*T2" in r["extra"]["held"] for r in records)


def test_slp_step_is_the_lp_optimum_with_the_constraint():
    """One LP of slp with a constraint row, against linprog posed directly."""
    c = np.array([1.0, 2.0])
    gradients, values, specs = np.array([[1.0, -1.0]]), np.array([1.0]), np.array([0.5])
    box = (np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    x0 = np.array([1.0, 1.0])
    A, b = np.array([[1.0, 3.0]]), np.array([5.0])
    got = solve_step(
        c, gradients, values, specs, box, (np.zeros((0, 2)), np.zeros(0)), x0, np.array([1.0]), 0.0, (A, b)
    )
    direct = linprog(
        -c,
        A_ub=np.vstack([-gradients, A]),
        b_ub=[values[0] - specs[0], b[0] - A[0] @ x0],
        bounds=list(zip(*box)),
        method="highs",
    )
    assert np.allclose(got.dx, direct.x) and A @ (x0 + got.dx) <= b + 1e-12


# -- qcg on report 001's Appendix C sample ---------------------------------------


@pytest.fixture(scope="module")
def constrained_optimum():
    """The sample's cost minimized with b21 >= 3 b1 by SLSQP (the unpenalized cost)."""
    cascade = cascade_problem(load_session(EXAMPLES / "seidel_inlet_pi.json").problem)

    def cost(x):
        result = cascade.cost({"b1": x[0], "b21": x[1]}, gradient=True)
        return result.F, np.array([result.gradient["b1"], result.gradient["b21"]])

    found = minimize(
        cost,
        [47.41, 145.0],
        jac=True,
        method="SLSQP",
        options={"ftol": 1e-14, "maxiter": 200},
        constraints=[{"type": "ineq", "fun": lambda x: x[1] - 3 * x[0], "jac": lambda x: np.array([-3.0, 1.0])}],
    )
    assert found.success
    return found.x, found.fun


@pytest.mark.parametrize("settings", [{}, {"optimizer": "lbfgsb"}])
def test_qcg_respects_a_constraint(tmp_path, constrained_optimum, settings):
    """The unconstrained optimum (47.41, 131.29) breaks b21 >= 3 b1; the runs end on it."""
    shutil.copy(EXAMPLES / "seidel_inlet_table1.csv", tmp_path)
    doc = json.loads((EXAMPLES / "seidel_inlet_pi.json").read_text())
    doc["problem"]["constraints"] = ["b21 >= 3*b1"]
    doc["algorithm"]["settings"].update(settings)
    records = _run(tmp_path, doc, "inlet")
    p, F = records[-1]["parameters"], records[-1]["extra"]["F"]
    x, F_opt = constrained_optimum
    assert 3 * p["b1"] - p["b21"] <= 0.0  # on the feasible side (the penalty's margin)
    assert 3 * p["b1"] - p["b21"] >= -1e-4 * p["b21"]  # and on the constraint
    assert F_opt * (1 - 1e-9) <= F <= F_opt * (1 + 1e-3)
    if settings:
        assert np.allclose([p["b1"], p["b21"]], x, rtol=1e-4)
        assert F == pytest.approx(F_opt, rel=1e-6)
    session = load_session(tmp_path / "inlet.json")
    adopt_parameters(session, p)  # the design is a start the constraint admits
    assert session.problem.vector().tolist() == [p["b1"], p["b21"]]


def test_rows_fold_fixed_and_per_condition_parameters():
    """A fixed parameter moves into b; a per-condition one without a condition gives a row per condition."""
    problem = load_session(EXAMPLES / "seidel_inlet_pi.json").problem
    problem = replace(
        problem,
        parameters=problem.parameters + (Parameter("c", 2.0, free=False),),
        inequalities=(LinearInequality((("b21", None, -1.0), ("b1", None, 3.0), ("c", None, 4.0)), 1.0),),
    )
    rows = inequality_rows(problem)
    assert np.array_equal(rows.A, [[3.0, -1.0]]) and np.array_equal(rows.b, [1.0 - 8.0])
    A, b = problem.linear_constraints
    assert np.array_equal(A, rows.A) and not A.flags.writeable

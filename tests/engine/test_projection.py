"""`projection` (report 004): the discretization, the banded KKT projection
against the report's Riccati recursion and a dense solve, example (a),
disjoint sets, Theorem 3's example.  The reactor (example (b)) is in
test_projection_reactor.py."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import cont2discrete

from engine.design.problem import Grid, Objective, Problem
from engine.errors import EngineError
from engine.projection import Projection, ProjectionSettings
from engine.projection.banded import Projector
from engine.projection.lq import Trajectory
from engine.projection.system import dae_system
from engine.stepping.driver import iterate
from engine.stepping.protocol import Status
from sessions.store import load_session
from tests.engine.projection_references import RiccatiProjector, kkt_projection

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


@pytest.fixture(scope="module")
def integrator():
    return load_session(EXAMPLES / "projection_integrator.json").problem


def _data(problem: Problem) -> dict:
    return dict(problem.objective.data)


def test_discretization_matches_scipy_zero_order_hold(integrator):
    system = dae_system(_data(integrator))
    Phi, Delta = system.discrete()
    n, m = system.n, system.m
    Ad, Bd, *_ = cont2discrete((system.A, system.B, np.eye(n), np.zeros((n, m))), 1.0 / system.steps)
    assert np.allclose(Phi, Ad, atol=1e-14) and np.allclose(Delta, Bd, atol=1e-14)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_banded_and_riccati_projections_equal_the_direct_kkt_solve(integrator, seed):
    rng = np.random.default_rng(seed)
    data = _data(integrator)
    if seed == 2:  # a random system: 5 states, 4 inputs, 2 algebraic equations, non-diagonal weights
        M = rng.normal(size=(5, 5))
        data = {
            "A": rng.normal(size=(5, 5)).tolist(),
            "B": rng.normal(size=(5, 4)).tolist(),
            "E": rng.normal(size=(2, 4)).tolist(),
            "F": rng.normal(size=(2, 5)).tolist(),
            "x0": rng.normal(size=5).tolist(),
            "horizon": 2.0,
            "steps": 15,
            "Q": (M @ M.T + np.eye(5)).tolist(),
            "R": [1.0, 2.0, 0.5, 3.0],
        }
    system = dae_system(data)
    reference = Trajectory(rng.normal(size=(system.steps + 1, system.n)), rng.normal(size=(system.steps + 1, system.m)))
    direct = kkt_projection(system, reference)
    scale = max(np.abs(direct.x).max(), np.abs(direct.u).max())
    for projected in (Projector(system)(reference), RiccatiProjector(system)(reference)):
        assert np.abs(projected.x - direct.x).max() <= 1e-10 * scale
        assert np.abs(projected.u - direct.u).max() <= 1e-10 * scale


def test_example_a_converges_with_extrapolation_much_faster_than_without(integrator):
    fast = [r for _, r in iterate(Projection.bind(integrator, ProjectionSettings()), max_iter=100)]
    slow = [r for _, r in iterate(Projection.bind(integrator, ProjectionSettings(extrapolation=False)), max_iter=500)]
    assert fast[-1].status is Status.CONVERGED and slow[-1].status is Status.CONVERGED
    updates_fast, updates_slow = len(fast) - 1, len(slow) - 1
    assert updates_fast <= 12 and updates_slow >= 3 * updates_fast
    assert all(r.extra["lambda"] >= 1.0 for r in fast[:-1])
    u = np.array(fast[-1].extra["u"])
    for name, value in fast[-1].extra["violations"].items():
        assert value <= 1e-8, name
    assert u[:, 2].min() >= -1e-8


def test_disjoint_sets_are_reported_infeasible_with_the_closest_distance(integrator):
    data = dict(_data(integrator), u_min=[10.0, 10.0, 10.0], x_min=[-1.0] * 4, x_max=[1.0] * 4)
    problem = replace(integrator, objective=replace(integrator.objective, data=data))
    plain = [r for _, r in iterate(Projection.bind(problem, ProjectionSettings(extrapolation=False)), max_iter=500)]
    extrapolated = [r for _, r in iterate(Projection.bind(problem, ProjectionSettings()), max_iter=500)]
    for records in (plain, extrapolated):
        assert records[-1].status is Status.INFEASIBLE and "u1" in records[-1].reason
    assert extrapolated[-1].extra["distance"] == pytest.approx(plain[-1].extra["distance"], rel=1e-6)


def test_bad_systems_are_refused(integrator):
    data = _data(integrator)
    for change, message in (
        (dict(u_max=[None, None, -1.0]), "box is empty"),
        (dict(E=[[1, 1, 1], [2, 2, 2]]), "full row rank"),
        (dict(Q=[[1, 0.1, 0, 0], [0.1, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]), "diagonal"),
        (dict(B=[[0, 0]]), "rows"),
    ):
        with pytest.raises(EngineError, match=message):
            dae_system(dict(data, **change))
    with pytest.raises(EngineError, match="dae"):
        Problem((), (), (), Grid(np.array([1.0, 2.0])), Objective("quadratic_cost"))


def test_theorem_3_converges_in_one_iteration_to_the_minimum_norm_control():
    """u(t) = -2 + 6t (report 004, Theorem 3's example); the held control's error shrinks as h^2."""
    session = load_session(EXAMPLES / "projection_hyperplane.json")
    errors = []
    for steps in (20, 80):
        data = dict(session.problem.objective.data, steps=steps)
        problem = replace(session.problem, objective=replace(session.problem.objective, data=data))
        records = [r for _, r in iterate(Projection.bind(problem, ProjectionSettings()), max_iter=20)]
        assert records[-1].status is Status.CONVERGED and len(records) == 2
        assert records[0].extra["lambda"] == pytest.approx(4.0, rel=1e-2)
        t, u = np.array(records[-1].extra["t"]), np.array(records[-1].extra["u"])[:, 0]
        middle = t[:-1] + 0.5 / steps
        errors.append(np.abs(u[:-1] - (-2 + 6 * middle)).max())
    assert errors[1] < errors[0] / 10 and errors[1] < 1e-3


def test_an_unreachable_terminal_state_is_an_error():
    """x' = 0 u cannot reach x(1) = 1: the KKT system is singular, and the factorization says so."""
    data = {
        "A": [[0.0]],
        "B": [[0.0]],
        "Q": [0.0],
        "R": [1.0],
        "x0": [0.0],
        "steps": 5,
        "terminal": [{"state": 1, "value": 1.0}],
    }
    with pytest.raises(EngineError, match="singular"):
        Projector(dae_system(data))

"""State-space blocks kept as state space (engine/model/state_space.py): the modal
and Hessenberg evaluations, the transmission zeros with the infinite ones
deflated, the pole-zero form, and the loop's closed-loop poles and step
response, each against python-control on the same matrices."""

from __future__ import annotations

import control
import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback
from engine.closed_loop.time_response import Segment, simulate
from engine.errors import BlockError
from engine.loop.design import design
from engine.model.blocks import StateSpaceTransfer
from engine.model.state_space import HessenbergLU, Response, checked, transmission_zeros

S = 1j * np.geomspace(1e-2, 1e3, 60)


def _random(n: int, seed: int) -> control.StateSpace:
    np.random.seed(seed)
    return control.rss(n, 1, 1)


def _jordan(n: int) -> tuple[np.ndarray, ...]:
    """A defective A (one Jordan block at -1): no modal form, so the Hessenberg path."""
    A = -np.eye(n) + np.diag(np.ones(n - 1), 1)
    B, C = np.arange(1.0, n + 1), np.cos(np.arange(n))
    return A, B, C, 0.3


def test_the_modal_path_matches_python_control_value_and_slope():
    sys = _random(12, 1)
    r = Response(checked(sys.A, sys.B, sys.C, sys.D, "t"))
    assert r.modal
    value, slope = r(S)
    assert np.allclose(value, sys(S).ravel(), rtol=1e-12)
    h = 1e-7 * np.abs(S)
    assert np.allclose(slope, (r(S + h)[0] - r(S - h)[0]) / (2 * h), rtol=1e-5)


def test_the_hessenberg_path_matches_python_control_value_and_slope():
    A, B, C, D = _jordan(6)
    sys = control.ss(A, B[:, None], C[None, :], D)
    r = Response(checked(A, B, C, D, "t"))
    assert not r.modal
    value, slope = r(S)
    assert np.allclose(value, sys(S).ravel(), rtol=1e-12)
    exact = -np.array([C @ np.linalg.solve(s * np.eye(6) - A, np.linalg.solve(s * np.eye(6) - A, B)) for s in S])
    assert np.allclose(slope, exact, rtol=1e-12)


def test_the_hessenberg_factors_solve_like_a_dense_solve_with_pivoting():
    rng = np.random.default_rng(3)
    h = np.triu(rng.standard_normal((9, 9)), -1)
    points = np.array([0.3j, 2.0 + 1e-9j, -1.0 + 4.0j, 1e6j])
    rhs = rng.standard_normal((points.size, 9)) + 1j * rng.standard_normal((points.size, 9))
    x = HessenbergLU(h, points).solve(rhs)
    for k, s in enumerate(points):
        assert np.allclose(x[k], np.linalg.solve(s * np.eye(9) - h, rhs[k]), rtol=1e-12, atol=0)


def test_a_high_relative_degree_has_no_spurious_zeros():
    """A chain of 6 integrators-with-poles, C at the end: relative degree 6 and no finite
    zero (a QZ of the whole pencil returns values of size ~ eps^(-1/6) there)."""
    n = 6
    A = np.diag(-np.arange(1.0, n + 1)) + np.diag(np.ones(n - 1), -1)
    B, C = np.eye(n)[0], np.eye(n)[-1]
    zeros = transmission_zeros(checked(A, B, C, 0.0, "t"))
    assert zeros is not None and zeros.size == 0
    form = StateSpaceTransfer(A, B, C).form
    assert form.gain == pytest.approx(1.0, rel=1e-12)
    assert np.allclose(np.sort(form.poles.real), -np.arange(n, 0, -1.0), rtol=1e-12)


def test_zeros_with_and_without_feedthrough_are_python_control_s():
    """Before cancellation (rss leaves some modes unreachable: a zero on such a pole)."""
    for sys in (_random(10, 4), control.ss(_random(10, 5).A, _random(10, 5).B, _random(10, 5).C, 0.0)):
        zeros = transmission_zeros(checked(sys.A, sys.B, sys.C, sys.D, "t"))
        expected = sys.zeros()
        assert zeros.size == expected.size
        for z in expected:
            assert np.min(np.abs(zeros - z)) <= 1e-8 * max(1.0, abs(z))
        form = StateSpaceTransfer(sys.A, sys.B, sys.C, sys.D).form
        # the second draw's A has norm 2e5 for eigenvalues below 12 (cond 6e9): every evaluation's
        # digits go to 1e-8 there (python-control's, the Hessenberg solve's, the form's)
        assert np.allclose(form.evaluate(S)[0], sys(S).ravel(), rtol=1e-7)


def test_the_deflation_is_blind_to_the_scale_of_b_and_c():
    """B of size 1e-200 (its square underflows) and C of 1e150: the same zeros, the gain 1e-50 times."""
    sys = _random(7, 8)
    plain = StateSpaceTransfer(sys.A, sys.B, sys.C, 0.0).form
    scaled = StateSpaceTransfer(sys.A, 1e-200 * sys.B, 1e150 * sys.C, 0.0).form
    assert np.allclose(np.sort_complex(scaled.zeros), np.sort_complex(plain.zeros), rtol=1e-10)
    assert scaled.gain == pytest.approx(1e-50 * plain.gain, rel=1e-10)


def test_a_zero_transfer_has_gain_zero_and_a_static_gain_no_roots():
    zero = StateSpaceTransfer(np.diag([-1.0, -2.0]), [1.0, 0.0], [0.0, 1.0]).form  # the input never reaches C
    assert zero.gain == 0.0
    for no_states in (np.zeros((0, 0)), []):
        static = StateSpaceTransfer(no_states, [], [], 2.5).form
        assert static.gain == 2.5 and static.zeros.size == 0 and static.poles.size == 0
    with pytest.raises(Exception, match="0 at every frequency"):
        unity_feedback(["1"], state_space=StateSpaceTransfer(np.diag([-1.0, -2.0]), [1.0, 0.0], [0.0, 1.0]))


@pytest.mark.parametrize(
    "matrices, message",
    [
        ((np.ones((2, 3)), [1, 1], [1, 1], 0), "A must be a square matrix"),
        ((np.eye(2), [1, 1, 1], [1, 1], 0), "B is 3"),
        ((np.eye(2), [1, 1], np.ones((2, 2)), 0), "C is 2 x 2"),
        ((np.eye(2), [1, 1], [1, 1], [1, 2]), "D is 2"),
        ((np.eye(2), [1, np.nan], [1, 1], 0), "B has a value that is not finite"),
        ((np.eye(401), np.ones(401), np.ones(401), 0), "beyond the limit of 400"),
        ((np.full((2, 2), 1e308), [1e308, 1], [1e308, 1e308], 1e308), "leave the floating-point range"),
    ],
)
def test_bad_matrices_are_refused_naming_the_source(matrices, message):
    with pytest.raises(BlockError, match=message) as refused:
        StateSpaceTransfer(*matrices, source="plant.npz")
    assert "plant.npz" in str(refused.value)


def test_a_loop_with_a_state_space_block_and_a_compensator_closes_as_python_control_s():
    """Margins, closed-loop poles and a step response of K(s) G(s), G as state space."""
    plant = _random(8, 11)
    network = unity_feedback(
        ["K*(1 + 0.5*s)/(1 + 0.05*s)"], state_space=StateSpaceTransfer(plant.A, plant.B, plant.C, plant.D)
    )
    params = {"K": 0.7}
    loop = control.tf([0.7 * 0.5, 0.7], [0.05, 1.0]) * plant
    result = analyze(network, "e", np.geomspace(1e-2, 1e3, 300), params)
    expected = np.sort_complex(control.feedback(loop, 1).poles())
    got = np.sort_complex(np.array([p.value for p in result.closed_loop_poles]))
    assert np.allclose(got, expected, rtol=1e-9)
    gm, pm, _, wg, wp, _ = control.stability_margins(loop, returnall=True)
    for value, frequency in zip(gm, wg):
        found = [g for g in result.margins.listed("G") if abs(g.frequency - frequency) <= 1e-6 * max(1, frequency)]
        assert found and found[0].gain_db == pytest.approx(20 * np.log10(value), abs=1e-6)
    for value, frequency in zip(pm, wp):
        found = [p for p in result.margins.phase if abs(p.frequency - frequency) <= 1e-6 * frequency]
        assert found and found[0].phase_deg == pytest.approx(value, abs=1e-6)
    t = np.linspace(0.0, 5.0, 201)
    closed = design(network, params).closed_realization
    y = simulate(closed, "r", t, [Segment(0.0, 1.0, 0.0)])[:, closed.outputs.index("y")]
    reference = control.step_response(control.feedback(loop, 1), t).outputs
    assert np.allclose(y, reference, rtol=1e-6, atol=1e-8 * np.max(np.abs(reference)))

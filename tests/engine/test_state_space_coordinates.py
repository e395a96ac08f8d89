"""Issue 49, section 1: a state space's results do not depend on its state coordinates.

The reference is the same system in well-conditioned coordinates (A = Q diag(blocks) Q'
with Q a random rotation: its eigenvalues conditioned near 1), and numpy's eigenvalues of
its closed loop A - B C / (1 + D) under unity negative feedback.  The model under test is
that system with its states scaled by powers of two up to 2^+-40 (exact: the same transfer
function to the last bit).  Before balancing, these listed thousands of spurious margins,
called closed loops with right-half-plane poles stable, and took seconds to minutes.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import linalg

from engine.analysis import CROSSING_BACKWARD_ERROR, _crossing_note, analyze, crossing_backward_errors, unity_feedback
from engine.loop.responses import loop_model
from engine.model.blocks import StateSpaceTransfer

OMEGA = np.geomspace(1e-3, 1e4, 200)
RTOL = 1e-8


def model(order: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """A, B, C, D of the given order: lightly damped pairs (damping 0.001-0.05) and real poles
    over five decades, rotated by a random orthogonal Q; B, C, D standard normal."""
    rng = np.random.default_rng(seed)
    pairs = int(rng.integers(0, order // 2 + 1))
    w, zeta = 10 ** rng.uniform(-2, 3, pairs), rng.uniform(0.001, 0.05, pairs)
    blocks = [np.array([[-z * x, x * np.sqrt(1 - z * z)], [-x * np.sqrt(1 - z * z), -z * x]]) for x, z in zip(w, zeta)]
    blocks += [np.array([[-(10 ** rng.uniform(-2, 3))]]) for _ in range(order - 2 * pairs)]
    q = np.linalg.qr(rng.standard_normal((order, order)))[0]
    return q @ linalg.block_diag(*blocks) @ q.T, rng.standard_normal(order), rng.standard_normal(order), 0.0


def scaled(A, B, C, seed: int, exponent: int = 40) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The same system with x = t x', t_i = 2^k_i, k_i uniform in -exponent..exponent."""
    t = 2.0 ** np.random.default_rng(seed + 1000).integers(-exponent, exponent + 1, A.shape[0])
    return A * t[None, :] / t[:, None], B / t, C * t


def margins_of(result) -> tuple[np.ndarray, np.ndarray]:
    """Gain margins (frequency, |1/GH|) and phase margins (frequency, degrees)."""
    m = result.margins
    gain = np.array([(g.frequency, 10 ** (-g.gain_db / 20)) for g in m.listed("G")]).reshape(-1, 2)
    phase = np.array([(p.frequency, p.phase_deg) for p in m.phase]).reshape(-1, 2)
    return gain, phase


def closed_loop_eigenvalues(A, B, C, D) -> np.ndarray:
    return np.linalg.eigvals(A - np.outer(B, C) / (1.0 + D))


CASES = [(6, 7), (12, 14), (17, 21), (20, 24), (23, 28), (34, 42), (8, 9), (15, 18)]


@pytest.mark.parametrize(("order", "seed"), CASES)
def test_a_state_space_scaled_by_powers_of_two_has_the_margins_and_poles_of_the_rotated_one(order, seed):
    A, B, C, D = model(order, seed)
    As, Bs, Cs = scaled(A, B, C, seed)
    reference = analyze(unity_feedback(["1"], state_space=StateSpaceTransfer(A, B, C, D)), "e", OMEGA, {})
    result = analyze(unity_feedback(["1"], state_space=StateSpaceTransfer(As, Bs, Cs, D)), "e", OMEGA, {})
    for ours, theirs in zip(margins_of(result), margins_of(reference)):
        assert ours.shape == theirs.shape, (ours, theirs)
        np.testing.assert_allclose(ours[:, 0], theirs[:, 0], rtol=RTOL)
    np.testing.assert_allclose(margins_of(result)[0][:, 1], margins_of(reference)[0][:, 1], rtol=RTOL)
    np.testing.assert_allclose(margins_of(result)[1][:, 1], margins_of(reference)[1][:, 1], atol=RTOL * 180)
    truth = closed_loop_eigenvalues(A, B, C, D)
    assert result.verdict == ("unstable" if np.any(truth.real > 0) else "stable")
    ours = np.array([p.value for p in result.closed_loop_poles])
    assert ours.size == truth.size
    nearest = np.abs(ours[:, None] - truth[None, :]).min(axis=1)
    assert np.all(nearest <= 1e-8 * np.abs(truth).max()), nearest.max()


@pytest.mark.parametrize("seed", range(4))
def test_the_block_poles_are_those_of_the_rotated_model_with_small_backward_errors(seed):
    A, B, C, D = model(30, seed)
    block = StateSpaceTransfer(*scaled(A, B, C, seed), D)
    truth = np.linalg.eigvals(A)
    nearest = np.abs(block.response.poles[:, None] - truth[None, :]).min(axis=1)
    assert np.all(nearest <= 1e-9 * np.abs(truth)), (nearest / np.abs(truth)).max()
    assert np.all(block.response.pole_errors <= 1e-13)
    assert block.note is None


def test_a_model_ill_conditioned_even_balanced_says_so_in_one_line():
    """A chain of nearly equal poles (a perturbed Jordan block): its eigenvectors are nearly
    parallel in any diagonal scaling (cond(V) about 1e28 here)."""
    n = 12
    A = np.diag(-1.0 - 1e-3 * np.arange(n)) + np.diag(np.ones(n - 1), 1)
    As, Bs, Cs = scaled(A, np.ones(n), np.ones(n), 5, exponent=20)
    block = StateSpaceTransfer(As, Bs, Cs, 0.0, source="chain.json")
    assert np.linalg.cond(np.linalg.eig(A)[1]) > 1e12  # the premise, from numpy on the unscaled chain
    result = analyze(unity_feedback(["1"], state_space=block), "e", OMEGA, {})
    notes = [n for n in result.notes if n.startswith("chain.json: ill-conditioned even balanced")]
    assert len(notes) == 1 and "\n" not in notes[0] and "not vouched for" in notes[0]


@pytest.mark.parametrize(("order", "seed"), [(15, 18), (20, 24)])
def test_every_crossing_carries_its_backward_error_in_the_given_coordinates(order, seed):
    """Issue 49, section 1: crossings within 1e-10 relative backward error measured in the scaled
    coordinates (a note says how large at most), or a note naming each that is not: a crossing's
    frequency moved by 1 % (no longer a crossing of the model: 4e-7) is named.  Reference for
    the residual: GH of the rotated model by a dense solve, which the scaled one must match."""
    A, B, C, D = model(order, seed)
    network = unity_feedback(["1"], state_space=StateSpaceTransfer(*scaled(A, B, C, seed), D))
    result = analyze(network, "e", OMEGA, {})
    crossings = [m for m in result.margins.gain if m.kind == "G"] + list(result.margins.phase)
    loop = loop_model(network, "e", OMEGA, {})
    errors = crossing_backward_errors(network, loop, result.margins)
    assert [m for m, _ in errors] == crossings and len(crossings) >= 4
    assert all(e <= CROSSING_BACKWARD_ERROR for _, e in errors)
    assert any(f"{len(crossings)} crossing(s) checked in the state space's own coordinates" in n for n in result.notes)
    for m in crossings:  # the rotated model's GH = -G (unity negative feedback): a crossing there too
        gh = -(C @ np.linalg.solve(1j * m.frequency * np.eye(order) - A, B) + D)
        assert (abs(gh.imag) if m.kind == "G" else abs(abs(gh) - 1)) <= 1e-9 * abs(gh)
    moved = replace(crossings[0], frequency=crossings[0].frequency * 1.01)
    off = (
        replace(result.margins, phase=(moved,), gain=())
        if moved.kind == "P"
        else replace(result.margins, gain=(moved,), phase=())
    )
    [(_, error)] = crossing_backward_errors(network, loop, off)
    assert error > 10 * CROSSING_BACKWARD_ERROR
    [note] = _crossing_note(network, loop, off)
    assert f"{moved.kind} at {moved.frequency:.6g} rad/s" in note and "not vouched for" in note


def test_a_plant_s_break_margins_compute_no_pole_backward_errors_which_the_note_computes_once(monkeypatch):
    """The poles' backward errors serve the conditioning note alone: a plant's breaks build one state
    space each and their margins do not read the note, so no break pays for them (each did: an
    eigenvector residual per break); a note read computes them once, as at construction before."""
    import engine.model.state_space as state_space
    from engine.multiloop.loops import break_margins
    from engine.multiloop.plant import checked_plant
    from tests.engine.multiloop_references import random_plant

    computed = []
    original = state_space.pole_backward_errors
    monkeypatch.setattr(
        state_space, "pole_backward_errors", lambda *args: computed.append(1) or original(*args), raising=True
    )
    plant = checked_plant(*random_plant(np.random.default_rng(3), 10, 2), "plant")
    assert len(break_margins(plant, OMEGA)) == 2 and not computed
    A, B, C, D = model(12, 1)
    block = StateSpaceTransfer(*scaled(A, B, C, 1), D)
    assert not computed and block.note is None and block.note is None and len(computed) == 1
    assert np.all(block.response.pole_errors <= 1e-13) and len(computed) == 1

"""Many closed loops' time responses at once (issue 53, section 1: time rows batched): every
sample's response from `engine.closed_loop.batch_time` is `simulate`'s for it, on random
stable realizations under a profile of ramps with breakpoints
off the grid and a step."""

from __future__ import annotations

import numpy as np

from engine.closed_loop.batch_time import batch_simulate, batch_simulate_sampled
from engine.closed_loop.time_response import Segment, simulate
from engine.loop.realization import StateSpace


def _random_loops(rng: np.random.Generator, count: int, n: int) -> tuple[np.ndarray, ...]:
    """Stable A (eigenvalues moved left of -0.05), B, C, D."""
    A = rng.normal(size=(count, n, n))
    shift = np.max(np.linalg.eigvals(A).real, axis=1) + 0.05
    A -= shift[:, None, None] * np.eye(n)
    return A, rng.normal(size=(count, n)), rng.normal(size=(count, n)), rng.normal(size=count)


def test_every_sample_is_simulate_s_response():
    rng = np.random.default_rng(53)
    t = np.linspace(0.0, 12.0, 301)
    segments = [Segment(0.0, 1.0, 0.0), Segment(1.234, 0.0, 0.5), Segment(4.567, -0.5, -0.5)]
    for n in (1, 4, 9):
        A, B, C, D = _random_loops(rng, 12, n)
        y = batch_simulate(A, B, C, D, t, segments)
        for k in range(A.shape[0]):
            ss = StateSpace(A[k], B[k][:, None], C[k][None, :], np.array([[D[k]]]), ("u",), ("y",))
            want = simulate(ss, "u", t, segments)[:, 0]
            assert np.max(np.abs(y[k] - want)) <= 1e-12 * np.max(np.abs(want))


def test_a_short_grid_and_no_states():
    t = np.array([0.0, 0.5])
    segments = [Segment(0.0, 1.0, 0.0)]
    A, B, C, D = np.zeros((3, 0, 0)), np.zeros((3, 0)), np.zeros((3, 0)), np.array([1.0, 2.0, 3.0])
    assert np.array_equal(batch_simulate(A, B, C, D, t, segments), [[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
    A, B, C, D = -np.ones((2, 1, 1)), np.ones((2, 1)), np.ones((2, 1)), np.zeros(2)
    ss = StateSpace(A[0], B[0][:, None], C[0][None, :], np.zeros((1, 1)), ("u",), ("y",))
    assert np.allclose(batch_simulate(A, B, C, D, t, segments)[1], simulate(ss, "u", t, segments)[:, 0], rtol=1e-14)


def test_every_sampled_loop_is_simulate_s_response_in_z():
    """A sampled loop's realizations in w (stable: Re w < 0, inside the unit circle in z) stepped
    at its samples, the output held between them (times off the samples included): each sample's
    response is `simulate`'s for its `StateSpace` with the sample time."""
    rng = np.random.default_rng(54)
    T = 0.25
    t = np.concatenate([np.arange(41) * T, [0.3, 1.11, 9.99]])
    t = np.unique(t)
    segments = [Segment(0.0, 1.0, 0.0), Segment(1.1, 0.0, 0.5), Segment(4.6, -0.5, -0.5)]
    for n in (1, 3, 6):
        A, B, C, D = _random_loops(rng, 10, n)
        y = batch_simulate_sampled(A, B, C, D, t, segments, T)
        for k in range(A.shape[0]):
            ss = StateSpace(A[k], B[k][:, None], C[k][None, :], np.array([[D[k]]]), ("u",), ("y",), T)
            want = simulate(ss, "u", t, segments)[:, 0]
            assert np.max(np.abs(y[k] - want)) <= 1e-12 * np.max(np.abs(want))

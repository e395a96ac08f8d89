"""Time responses of many closed loops of one structure at once: the samples of a tolerance
study, each a realization of the same shape (n states) with its own numbers.

The method is `engine.closed_loop.time_response.simulate`'s (continuous loops), every array
carrying a leading axis of samples: the grid joined with the profile's breakpoints, the
exact first-order hold of each run of equal steps (``scipy.linalg.expm`` of the stacked
augmented matrices, each scaled as its own), and the same blocked doubling scan, so each
sample's response is the one `simulate` gives for it, to rounding (the products are
grouped alike).  One recursion for a group of samples instead of one per sample, the groups
sized so that their powers and states stay within 8 MB (a 28-state loop: 20 samples a group).
It saves the per-sample Python calls, which is what a small loop's simulation costs; a
loop of some 30 states costs its matrix products either way.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.time_response import BLOCK, Segment, flush_subnormal, held_runs, input_profile

GROUP_ELEMENTS = 1 << 20  # floats of a group's powers (BLOCK n x n per sample) or states: 8 MB at most


def batch_simulate(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    C: NDArray[np.float64],
    D: NDArray[np.float64],
    t: NDArray[np.float64],
    segments: Sequence[Segment],
) -> NDArray[np.float64]:
    """The output (S, len(t)) of every sample's continuous loop x' = A x + B u, y = C x + D u
    (A (S, n, n), B and C (S, n), D (S,)) under the profile ``segments`` from a zero state:
    `simulate`'s response of each sample (``t`` starting at 0, strictly increasing)."""
    breaks = [s.time for s in segments if 0 < s.time < t[-1]]
    grid = np.unique(np.concatenate([t, breaks]))
    u = input_profile(grid, segments)
    u_left = np.where(np.isin(grid, breaks), input_profile(np.nextafter(grid, -np.inf), segments), u)
    n = A.shape[1]
    group = max(1, GROUP_ELEMENTS // max(1, BLOCK * n * max(n, grid.size // BLOCK + 1)))
    y = np.empty((A.shape[0], grid.size))
    for first in range(0, A.shape[0], group):  # the powers and states of a group of samples held at once
        part = slice(first, first + group)
        x = _propagate(A[part], B[part], grid, u, u_left)
        y[part] = np.einsum("sgn,sn->sg", x, C[part]) + u[None, :] * D[part, None]
    return y[:, np.isin(grid, t)]


def _propagate(A: NDArray, B: NDArray, grid: NDArray, u: NDArray, u_left: NDArray) -> NDArray:
    """Every sample's states on ``grid`` (S, G, n) under the piecewise linear input."""
    count, n = A.shape[0], A.shape[1]
    x = np.zeros((count, grid.size, n))
    if n == 0:
        return x
    du = (u_left[1:] - u[:-1]) / np.diff(grid)
    for a, b, (Phi, Gam0, Gam1) in held_runs(grid, lambda step: _foh(A, B, step)):
        forced = u[None, a:b, None] * Gam0[:, None, :] + du[None, a:b, None] * Gam1[:, None, :]
        x[:, a + 1 : b + 1] = _scan(Phi, x[:, a], forced)
    return x


def _foh(A: NDArray, B: NDArray, h: float) -> tuple[NDArray, NDArray, NDArray]:
    """Every sample's exact one-step maps for an input linear over [0, h] (`time_response._foh`)."""
    count, n = A.shape[0], A.shape[1]
    big = np.zeros((count, n + 2, n + 2))
    big[:, :n, :n], big[:, :n, n], big[:, n, n + 1] = A * h, B * h, 1.0
    from scipy.linalg import expm  # on first use (start-up)

    E = expm(big)
    return E[:, :n, :n], E[:, :n, n], E[:, :n, n + 1] * h


def _scan(Phi: NDArray, x0: NDArray, forced: NDArray) -> NDArray:
    """x[k+1] = Phi x[k] + forced[k] from x[0] = x0, every sample (``forced`` (S, L, n)): the
    states x[1:], by `time_response._scan`'s blocks and doubling."""
    count, L, n = forced.shape
    if L == 1:
        return np.einsum("sn,smn->sm", x0, Phi)[:, None, :] + forced
    m = min(BLOCK, L)
    nb = -(-L // m)
    powers = Phi.transpose(0, 2, 1)[:, None]  # powers[:, k] = (Phi^(k+1))^T
    while powers.shape[1] < m:
        powers = np.concatenate([powers, flush_subnormal(powers @ powers[:, -1:])], axis=1)
    z = np.zeros((count, nb * m, n))
    z[:, :L] = forced
    z = z.reshape(count, nb, m, n)
    d = 1
    while d < m:
        z[:, :, d:] = z[:, :, d:] + z[:, :, :-d] @ powers[:, None, d - 1]
        d *= 2
    starts = np.empty((count, nb, n))
    starts[:, 0] = x0
    for b in range(1, nb):
        starts[:, b] = (starts[:, b - 1, None, :] @ powers[:, m - 1])[:, 0] + z[:, b - 1, -1]
    stacked = powers[:, :m].transpose(0, 2, 1, 3).reshape(count, n, m * n)
    free = (starts @ stacked).reshape(count, nb, m, n)
    return (free + z).reshape(count, nb * m, n)[:, :L]

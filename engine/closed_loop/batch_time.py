"""Time responses of many closed loops of one structure at once: the samples of a tolerance
study, each a realization of the same shape (n states) with its own numbers.

The method is `engine.closed_loop.time_response.simulate`'s (continuous loops), every array
carrying a leading axis of samples: the grid joined with the profile's breakpoints, the
exact first-order hold of each run of equal steps (``scipy.linalg.expm`` of the stacked
augmented matrices, each scaled as its own), and the recursion x[k+1] = Phi x[k] + forced[k]
stepped directly, one product a step for every sample at once (`simulate`'s blocked doubling
saves a single loop's Python steps at some 20 times the products: a 28-state loop's 200
steps cost 5.6 million multiplications that way, 0.3 million directly), each output read
as its state is made (no states kept).  Each sample's response is the one `simulate` gives
for it to rounding (the products grouped otherwise: the tests hold 1e-12 of the response's
size).  A sampled loop (its realization in w) is taken to z and stepped at its samples alike
(`batch_simulate_sampled`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.time_response import MAX_SAMPLES, Segment, flush_subnormal, held_runs, input_profile
from engine.errors import EngineError
from engine.model.bilinear import realization_in_z

GROUP_ELEMENTS = 1 << 20  # floats of a group of samples' one-step maps (n x n each): 8 MB at most
FLUSH = 16  # steps between two flushes of subnormal states (slow to multiply)


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
    group = max(1, GROUP_ELEMENTS // max(1, n * n))
    y = np.empty((A.shape[0], grid.size))
    for first in range(0, A.shape[0], group):  # the one-step maps of a group of samples held at once
        part = slice(first, first + group)
        y[part] = _outputs(A[part], B[part], C[part], grid, u, u_left) + u[None, :] * D[part, None]
    return y[:, np.isin(grid, t)]


def batch_simulate_sampled(
    A: NDArray[np.float64],
    B: NDArray[np.float64],
    C: NDArray[np.float64],
    D: NDArray[np.float64],
    t: NDArray[np.float64],
    segments: Sequence[Segment],
    sample_time: float,
) -> NDArray[np.float64]:
    """The output (S, len(t)) of every sample's sampled loop (its realization in w: A (S, n, n), B
    and C (S, n), D (S,)), as `time_response.simulate` steps one: taken to z
    (`engine.model.bilinear.realization_in_z`, all at once), stepped at its samples j T with the
    input read at each, x[j+1] = A_z x[j] + B_z u[j] for every sample in one product a step, the
    output held between samples."""
    T = sample_time
    count = math.floor(t[-1] / T + 1e-9) + 1
    if count > MAX_SAMPLES:
        raise EngineError(f"{t[-1]:g} s is {count} samples of {T:g} s: more than {MAX_SAMPLES} in one response")
    Az, Bz, Cz, Dz = realization_in_z(A, B[:, :, None], C[:, None, :], D[:, None, None])
    u = input_profile(np.arange(count) * T, segments)
    y = np.empty((A.shape[0], count))
    x = np.zeros((A.shape[0], 1, A.shape[1]))
    transposed, forced = Az.transpose(0, 2, 1), Bz[:, :, 0][:, None, :]
    for k in range(count):
        y[:, k] = np.einsum("sn,sn->s", x[:, 0], Cz[:, 0]) + Dz[:, 0, 0] * u[k]
        if k + 1 < count:
            x = x @ transposed + u[k] * forced
            if k % FLUSH == 0:
                flush_subnormal(x)
    return y[:, np.floor(t / T + 1e-9).astype(int)]


def _outputs(A: NDArray, B: NDArray, C: NDArray, grid: NDArray, u: NDArray, u_left: NDArray) -> NDArray:
    """Every sample's C x on ``grid`` (S, G) under the piecewise linear input, from a zero state."""
    count, n = A.shape[0], A.shape[1]
    y = np.zeros((count, grid.size))
    if n == 0:
        return y
    du = (u_left[1:] - u[:-1]) / np.diff(grid)
    x = np.zeros((count, 1, n))
    for a, b, (Phi, Gam0, Gam1) in held_runs(grid, lambda step: _foh(A, B, step)):
        transposed = Phi.transpose(0, 2, 1)
        for k in range(a, b):
            x = x @ transposed + (u[k] * Gam0 + du[k] * Gam1)[:, None, :]
            if k % FLUSH == 0:
                flush_subnormal(x)
            y[:, k + 1] = np.einsum("sn,sn->s", x[:, 0], C)
    return y


def _foh(A: NDArray, B: NDArray, h: float) -> tuple[NDArray, NDArray, NDArray]:
    """Every sample's exact one-step maps for an input linear over [0, h] (`time_response._foh`)."""
    count, n = A.shape[0], A.shape[1]
    big = np.zeros((count, n + 2, n + 2))
    big[:, :n, :n], big[:, :n, n], big[:, n, n + 1] = A * h, B * h, 1.0
    from scipy.linalg import expm  # on first use (start-up)

    E = expm(big)
    return E[:, :n, :n], E[:, :n, n], E[:, :n, n + 1] * h

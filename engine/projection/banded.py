"""P_K2 by one banded LU factorization of the KKT system, made once per
system; each projection is one banded solve (LAPACK dgbtrf/dgbtrs), with no
loop over time steps in Python.

Unknowns, time step by time step (block k, size 2n + q):
    [lambda_k, x_k, v_k],   u_k = G x_k + N v_k   (`lq.Reduction`),
lambda_0 the multiplier of x_0 = x0 and lambda_k (k >= 1) that of
x_k - A x_{k-1} - B v_{k-1} = 0; then one multiplier per terminal equality.
Rows of the symmetric KKT matrix:
    lambda_k:  x_k - A x_{k-1} - B v_{k-1}             = 0   (x_0 = x0)
    x_k:       lambda_k - A'lambda_{k+1} + Qt x_k + S v_k = Q xr_k + G'R ur_k
    v_k:      -B'lambda_{k+1} + S'x_k + Rt v_k          = N'R ur_k
Every entry lies within 2n + q - 1 of the diagonal (more only with terminal
rows), so the band LU costs O(N (2n+q)^3) and a solve O(N (2n+q)^2): the
same work as the Riccati recursion, in compiled code.  The matrix is
scaled symmetrically (rows and columns by 1/sqrt of their largest entry)
before the factorization, since Q, R and the dynamics differ by many
orders of magnitude; with it the solve agrees with the Riccati recursion to
about 1e-15 (relative) on the reactor at N = 2000, so no refinement step.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

from engine.errors import EngineError
from engine.projection.lq import Trajectory, reduction
from engine.projection.system import DaeSystem


class Projector:
    """P_K2 for one system: the KKT matrix factored once, a banded solve per call."""

    def __init__(self, system: DaeSystem):
        self.system = system
        self.Phi, self.Delta = system.discrete()
        self.red = red = reduction(system, self.Phi, self.Delta)
        n, q, N = system.n, red.N.shape[1], system.steps
        self.block = b = 2 * n + q
        terminal = np.zeros((0, 2)) if system.terminal is None else system.terminal
        self.size = (N + 1) * b + len(terminal)
        t_index = terminal[:, 0].astype(int)
        # half bandwidth: -A (row lambda_k, column x_{k-1}) reaches b - 1; a terminal row N b + n + i to (N+1) b + t
        self.kl = kl = max([b - 1, *(b - n - i + t for t, i in enumerate(t_index))])
        band = np.zeros((2 * kl + 1, self.size))  # band[kl + i - j, j] = K[i, j]
        steps = band[:, : (N + 1) * b].reshape(2 * kl + 1, N + 1, b)
        every, later = np.arange(N + 1), np.arange(1, N + 1)
        for ks, row, col, M, shift in (
            (every, n, 0, np.eye(n), 0),
            (every, 2 * n, n, red.S.T, 0),
            (later, 0, n, -red.A, -1),
            (later, 0, 2 * n, -red.B, -1),
        ):
            _place(steps, kl, b, ks, row, col, M, shift)
            _place(steps, kl, b, ks + shift, col, row, M.T, -shift)
        _place(steps, kl, b, every, n, n, red.Qt, 0)
        _place(steps, kl, b, every, 2 * n, 2 * n, red.Rt, 0)
        for t, i in enumerate(t_index):  # x_N[i] = value: row and column (N+1) b + t
            r, c = (N + 1) * b + t, N * b + n + i
            band[kl + r - c, c] = band[kl + c - r, r] = 1.0
        self._factor(band)

    def _factor(self, band: NDArray) -> None:
        """Symmetric scaling by the largest entry of each row (= column: K is symmetric), then the band
        LU (kl = ku).  band[d, j] = K[j + d - kl, j]."""
        kl, size = self.kl, self.size
        largest = np.abs(band).max(axis=0)
        if np.any(largest == 0):
            raise EngineError("projection: the KKT system of the dynamics is singular (an empty row)")
        self.scale = scale = 1.0 / np.sqrt(largest)
        full = np.zeros((3 * kl + 1, size))  # dgbtrf wants kl more rows for the fill-in
        for d in range(2 * kl + 1):
            lo, hi = max(0, kl - d), min(size, size + kl - d)  # columns j whose row j + d - kl exists
            full[kl + d, lo:hi] = band[d, lo:hi] * scale[lo:hi] * scale[lo + d - kl : hi + d - kl]
        self.lu, self.piv, info = lapack.dgbtrf(full, kl, kl, overwrite_ab=1)
        if info != 0:
            raise EngineError(
                "projection: the KKT system of the dynamics is singular (E u + F x = 0 leaves "
                "no control, or the terminal states cannot be reached)"
            )

    def _solve(self, rhs: NDArray) -> NDArray:
        z, _ = lapack.dgbtrs(self.lu, self.kl, self.kl, (rhs * self.scale)[:, None], self.piv)
        return z[:, 0] * self.scale

    def __call__(self, reference: Trajectory) -> Trajectory:
        """The point of K2 nearest ``reference``."""
        s, red, b, n = self.system, self.red, self.block, self.system.n
        rhs = np.zeros((s.steps + 1, b))
        rhs[0, :n] = s.x0
        rhs[:, n : 2 * n], rhs[:, 2 * n :] = red.linear_terms(s, reference)
        rhs = rhs.ravel()
        if s.terminal is not None:
            rhs = np.concatenate([rhs, s.terminal[:, 1]])
        z = self._solve(rhs)[: (s.steps + 1) * b].reshape(s.steps + 1, b)
        x, v = z[:, n : 2 * n], z[:, 2 * n :]
        return Trajectory(x.copy(), x @ red.G.T + v @ red.N.T)


def _place(steps: NDArray, kl: int, b: int, ks: NDArray, row: int, col: int, M: NDArray, shift: int) -> None:
    """K[k b + row + i, (k + shift) b + col + j] = M[i, j] for every k in ks, into the band's
    (diagonal, step, column within the step) view."""
    i, j = np.indices(M.shape)
    diagonal = kl + row - col - shift * b + i - j
    steps[diagonal[None], (ks + shift)[:, None, None], (col + j)[None]] = M[None]

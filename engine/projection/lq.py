"""Projection onto K2 (the dynamics and the algebraic equations) in the
(Q, R) norm: LQ tracking with the constraint E u + F x = 0, by a Riccati
recursion whose matrices are computed once; only the tracking vector
changes with the reference (report 004, section 3 and Appendix A2).

The algebraic equation is eliminated as the appendix does: u = G x + N v
with G = -R^-1 E'(E R^-1 E')^-1 F (the appendix's K(0) for the last step)
and N a basis of the null space of E, so v is free; then a standard
finite-horizon recursion with cross terms.  `kkt_projection` solves the
same least-squares problem directly (the test's independent check).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import null_space

from .system import DaeSystem


@dataclass(frozen=True)
class Trajectory:
    """x: (N+1, n), u: (N+1, m)."""

    x: NDArray
    u: NDArray

    def __add__(self, other: Trajectory) -> Trajectory:
        return Trajectory(self.x + other.x, self.u + other.u)

    def __sub__(self, other: Trajectory) -> Trajectory:
        return Trajectory(self.x - other.x, self.u - other.u)

    def scaled(self, factor: float) -> Trajectory:
        return Trajectory(factor * self.x, factor * self.u)


def norm(t: Trajectory, Q: NDArray, R: NDArray) -> float:
    """sqrt(sum x'Qx + u'Ru)."""
    return float(np.sqrt(np.einsum("ki,ij,kj->", t.x, Q, t.x) + np.einsum("ki,ij,kj->", t.u, R, t.u)))


class Projector:
    """P_K2 for one system: the Riccati gains once, a tracking pass per call
    (with terminal equalities, the direct KKT solve instead)."""

    def __init__(self, system: DaeSystem):
        self.system = system
        Phi, Delta = system.discrete()
        self.Phi, self.Delta = Phi, Delta
        E, F, Q, R = system.E, system.F, system.Q, system.R
        Rinv = np.linalg.inv(R)
        if E.shape[0]:
            self.G = -Rinv @ E.T @ np.linalg.solve(E @ Rinv @ E.T, F)
            self.N = null_space(E)
        else:
            self.G, self.N = np.zeros((system.m, system.n)), np.eye(system.m)
        self.A = Phi + Delta @ self.G
        self.B = Delta @ self.N
        self.Qt = Q + self.G.T @ R @ self.G
        self.S = self.G.T @ R @ self.N
        self.Rt = self.N.T @ R @ self.N
        self._gains()

    def _gains(self) -> None:
        steps = self.system.steps
        n, q = self.system.n, self.N.shape[1]
        P = np.zeros((n, n))
        self.K, self.Hinv, self.C = [None] * (steps + 1), [None] * (steps + 1), [None] * (steps + 1)
        for k in range(steps, -1, -1):
            H = self.Rt + self.B.T @ P @ self.B
            C = self.S + self.A.T @ P @ self.B
            Hinv = np.linalg.inv(H) if q else np.zeros((0, 0))
            K = Hinv @ C.T
            self.K[k], self.Hinv[k], self.C[k] = K, Hinv, C
            P = self.Qt + self.A.T @ P @ self.A - C @ K
            P = 0.5 * (P + P.T)

    def __call__(self, reference: Trajectory) -> Trajectory:
        """The point of K2 nearest ``reference``."""
        if self.system.terminal is not None:
            return kkt_projection(self.system, reference)
        s, R, Q = self.system, self.system.R, self.system.Q
        q_lin = -(reference.x @ Q.T + reference.u @ R.T @ self.G)   # (N+1, n): -(Q xr + G'R ur)
        r_lin = -(reference.u @ R.T @ self.N)                        # (N+1, q): -N'R ur
        p = np.zeros(s.n)
        g = [None] * (s.steps + 1)
        for k in range(s.steps, -1, -1):
            d = r_lin[k] + self.B.T @ p
            g[k] = -self.Hinv[k] @ d
            p = q_lin[k] + self.A.T @ p - self.C[k] @ (self.Hinv[k] @ d)
        x = np.zeros((s.steps + 1, s.n))
        u = np.zeros((s.steps + 1, s.m))
        x[0] = s.x0
        for k in range(s.steps + 1):
            v = -self.K[k] @ x[k] + g[k]
            u[k] = self.G @ x[k] + self.N @ v
            if k < s.steps:
                x[k + 1] = self.A @ x[k] + self.B @ v
        return Trajectory(x, u)


def kkt_projection(system: DaeSystem, reference: Trajectory) -> Trajectory:
    """The same projection by one dense solve of the equality-constrained least squares."""
    Phi, Delta = system.discrete()
    n, m, N, p = system.n, system.m, system.steps, system.E.shape[0]
    nx, nu = (N + 1) * n, (N + 1) * m
    H = np.zeros((nx + nu, nx + nu))
    h = np.zeros(nx + nu)
    for k in range(N + 1):
        H[k * n:(k + 1) * n, k * n:(k + 1) * n] = system.Q
        H[nx + k * m:nx + (k + 1) * m, nx + k * m:nx + (k + 1) * m] = system.R
        h[k * n:(k + 1) * n] = system.Q @ reference.x[k]
        h[nx + k * m:nx + (k + 1) * m] = system.R @ reference.u[k]
    rows = []
    rhs = []
    first = np.zeros((n, nx + nu))
    first[:, :n] = np.eye(n)
    rows.append(first)
    rhs.append(system.x0)
    for k in range(N):
        block = np.zeros((n, nx + nu))
        block[:, (k + 1) * n:(k + 2) * n] = np.eye(n)
        block[:, k * n:(k + 1) * n] = -Phi
        block[:, nx + k * m:nx + (k + 1) * m] = -Delta
        rows.append(block)
        rhs.append(np.zeros(n))
    for k in range(N + 1):
        block = np.zeros((p, nx + nu))
        block[:, k * n:(k + 1) * n] = system.F
        block[:, nx + k * m:nx + (k + 1) * m] = system.E
        rows.append(block)
        rhs.append(np.zeros(p))
    for index, value in (system.terminal if system.terminal is not None else []):
        row = np.zeros((1, nx + nu))
        row[0, N * n + int(index)] = 1.0
        rows.append(row)
        rhs.append(np.array([value]))
    Aeq, b = np.vstack(rows), np.concatenate(rhs)
    kkt = np.block([[H, Aeq.T], [Aeq, np.zeros((Aeq.shape[0], Aeq.shape[0]))]])
    z = np.linalg.solve(kkt, np.concatenate([h, b]))
    return Trajectory(z[:nx].reshape(N + 1, n), z[nx:nx + nu].reshape(N + 1, m))

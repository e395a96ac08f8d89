"""The two reference methods of projection onto K2, against which the banded KKT
factorization the algorithm uses (engine/projection/banded.py) is checked: the
report's Riccati recursion (section 3 and Appendix A2: gains once, a tracking
pass per reference) and one dense solve of the equality-constrained least
squares."""

from __future__ import annotations

import numpy as np

from engine.projection.lq import Trajectory, reduction
from engine.projection.system import DaeSystem


class RiccatiProjector:
    """P_K2 as the report computes it: the Riccati gains once, then a backward
    tracking pass and a forward run per reference (a Python loop per step;
    no terminal equalities)."""

    def __init__(self, system: DaeSystem):
        self.system = system
        self.red = reduction(system, *system.discrete())
        red, n, q = self.red, system.n, self.red.N.shape[1]
        P = np.zeros((n, n))
        self.K, self.Hinv, self.C = ([None] * (system.steps + 1) for _ in range(3))
        for k in range(system.steps, -1, -1):
            H = red.Rt + red.B.T @ P @ red.B
            C = red.S + red.A.T @ P @ red.B
            Hinv = np.linalg.inv(H) if q else np.zeros((0, 0))
            self.K[k], self.Hinv[k], self.C[k] = Hinv @ C.T, Hinv, C
            P = red.Qt + red.A.T @ P @ red.A - C @ self.K[k]
            P = 0.5 * (P + P.T)

    def __call__(self, reference: Trajectory) -> Trajectory:
        """The point of K2 nearest ``reference``."""
        s, red = self.system, self.red
        hx, hv = red.linear_terms(s, reference)
        p = np.zeros(s.n)
        g = [None] * (s.steps + 1)
        for k in range(s.steps, -1, -1):
            d = -hv[k] + red.B.T @ p
            g[k] = -self.Hinv[k] @ d
            p = -hx[k] + red.A.T @ p - self.C[k] @ (self.Hinv[k] @ d)
        x = np.zeros((s.steps + 1, s.n))
        u = np.zeros((s.steps + 1, s.m))
        x[0] = s.x0
        for k in range(s.steps + 1):
            v = -self.K[k] @ x[k] + g[k]
            u[k] = red.G @ x[k] + red.N @ v
            if k < s.steps:
                x[k + 1] = red.A @ x[k] + red.B @ v
        return Trajectory(x, u)


def kkt_projection(system: DaeSystem, reference: Trajectory) -> Trajectory:
    """The same projection by one dense solve of the equality-constrained least squares."""
    Phi, Delta = system.discrete()
    n, m, N, p = system.n, system.m, system.steps, system.E.shape[0]
    nx, nu = (N + 1) * n, (N + 1) * m
    H = np.zeros((nx + nu, nx + nu))
    h = np.zeros(nx + nu)
    for k in range(N + 1):
        H[k * n : (k + 1) * n, k * n : (k + 1) * n] = system.Q
        H[nx + k * m : nx + (k + 1) * m, nx + k * m : nx + (k + 1) * m] = system.R
        h[k * n : (k + 1) * n] = system.Q @ reference.x[k]
        h[nx + k * m : nx + (k + 1) * m] = system.R @ reference.u[k]
    rows = []
    rhs = []
    first = np.zeros((n, nx + nu))
    first[:, :n] = np.eye(n)
    rows.append(first)
    rhs.append(system.x0)
    for k in range(N):
        block = np.zeros((n, nx + nu))
        block[:, (k + 1) * n : (k + 2) * n] = np.eye(n)
        block[:, k * n : (k + 1) * n] = -Phi
        block[:, nx + k * m : nx + (k + 1) * m] = -Delta
        rows.append(block)
        rhs.append(np.zeros(n))
    for k in range(N + 1):
        block = np.zeros((p, nx + nu))
        block[:, k * n : (k + 1) * n] = system.F
        block[:, nx + k * m : nx + (k + 1) * m] = system.E
        rows.append(block)
        rhs.append(np.zeros(p))
    for index, value in system.terminal if system.terminal is not None else []:
        row = np.zeros((1, nx + nu))
        row[0, N * n + int(index)] = 1.0
        rows.append(row)
        rhs.append(np.array([value]))
    Aeq, b = np.vstack(rows), np.concatenate(rhs)
    kkt = np.block([[H, Aeq.T], [Aeq, np.zeros((Aeq.shape[0], Aeq.shape[0]))]])
    z = np.linalg.solve(kkt, np.concatenate([h, b]))
    return Trajectory(z[:nx].reshape(N + 1, n), z[nx : nx + nu].reshape(N + 1, m))

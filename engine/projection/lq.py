"""What projection onto K2 (the dynamics and the algebraic equations) in the
(Q, R) norm is made of: trajectories, their norm, and the algebraic equation
eliminated.  The algorithm projects with the banded KKT factorization of
`banded.py`; the tests check it against the two reference methods
(tests/engine/projection_references.py: the report's Riccati recursion and
one dense solve).

The algebraic equation is eliminated as the appendix does: u = G x + N v
with G = -R^-1 E'(E R^-1 E')^-1 F (the appendix's K(0) for the last step)
and N a basis of the null space of E, so v is free; then a standard
finite-horizon problem in (x, v) with a cross term.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import null_space

from engine.projection.memory import Iterate
from engine.projection.system import DaeSystem


@dataclass(frozen=True)
class Trajectory:
    """x: (N+1, n), u: (N+1, m)."""

    x: NDArray
    u: NDArray

    @functools.cached_property
    def packed(self) -> Iterate:
        """The trajectory as tuples of rows (the memory's and the records' form), made once."""
        return Iterate(tuple(map(tuple, self.x.tolist())), tuple(map(tuple, self.u.tolist())), self)

    def __add__(self, other: Trajectory) -> Trajectory:
        return Trajectory(self.x + other.x, self.u + other.u)

    def __sub__(self, other: Trajectory) -> Trajectory:
        return Trajectory(self.x - other.x, self.u - other.u)

    def scaled(self, factor: float) -> Trajectory:
        return Trajectory(factor * self.x, factor * self.u)


def norm(t: Trajectory, Q: NDArray, R: NDArray) -> float:
    """sqrt(sum x'Qx + u'Ru)."""
    return float(np.sqrt(np.vdot(t.x @ Q, t.x) + np.vdot(t.u @ R, t.u)))


@dataclass(frozen=True)
class Reduction:
    """u = G x + N v; x(k+1) = A x(k) + B v(k); cost x'Qt x + 2 x'S v + v'Rt v."""

    G: NDArray
    N: NDArray
    A: NDArray
    B: NDArray
    Qt: NDArray
    S: NDArray
    Rt: NDArray

    def linear_terms(self, system: DaeSystem, reference: Trajectory) -> tuple[NDArray, NDArray]:
        """(Q xr + G'R ur, N'R ur) per step: the reference's linear terms in x and v."""
        R = system.R
        return reference.x @ system.Q + reference.u @ (R @ self.G), reference.u @ (R @ self.N)


def reduction(system: DaeSystem, Phi: NDArray, Delta: NDArray) -> Reduction:
    """The algebraic equation eliminated (see the module docstring)."""
    E, F, Q, R = system.E, system.F, system.Q, system.R
    if E.shape[0]:
        Rinv = np.linalg.inv(R)
        G = -Rinv @ E.T @ np.linalg.solve(E @ Rinv @ E.T, F)
        N = null_space(E)
    else:
        G, N = np.zeros((system.m, system.n)), np.eye(system.m)
    return Reduction(G, N, Phi + Delta @ G, Delta @ N, Q + G.T @ R @ G, G.T @ R @ N, N.T @ R @ N)

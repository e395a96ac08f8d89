"""A square plant x' = A x + B u, y = C x + D u of m inputs and m outputs under unity
negative feedback (u = -y), broken at its inputs.

Coordinates.  The states are scaled by powers of two first (LAPACK's gebal on the
realization [[A, B], [C, 0]], the states' part alone: exact), as a single-input model is
(`engine.model.state_space.balanced`): nothing below depends on the coordinates given.

The loop at break i.  Input i is cut (u_i = v, injected) and every other loop stays closed:
u_o = -y_o, so (I + D_oo) u_o = -(C_o x + D_oi v).  The single-input single-output loop is
L_i = y_i / v, a realization of the same n states (`loop_at`): closed with -1 it is the
whole closed loop again.  With unity feedback the loop matrix at the outputs (P K) is the
one at the inputs (K P): the breaks at the outputs see the same loops and the same margins.

The input sensitivity S = (I + P)^-1 (from a disturbance added at the inputs to u) is
(A - B F C, B F, -F C, F) with F = (I + D)^-1 (`sensitivity`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import EngineError
from engine.model.ports.state_space_ports import balanced_ports, checked_ports
from engine.model.state_space import Matrices

SINGULAR = 1e-12  # reciprocal condition of I + D (or I + D_oo) below which the loop is not well posed


@dataclass(frozen=True)
class Plant:
    """A (n x n), B (n x m), C (m x n), D (m x m), real and finite; ``names`` of the m breaks."""

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    names: tuple[str, ...]

    @property
    def order(self) -> int:
        return int(self.A.shape[0])

    @property
    def loops(self) -> int:
        return int(self.D.shape[0])

    def index(self, name: str) -> int:
        """The position of the break ``name``; an `EngineError` naming the breaks there are."""
        if name not in self.names:
            raise EngineError(f"break {name!r}: the plant's breaks are {', '.join(self.names)}")
        return self.names.index(name)


def input_count(B: ArrayLike, C: ArrayLike) -> tuple[int, int]:
    """(inputs, outputs) of a state space's B and C as given (a vector B: one input, a vector C:
    one output), for telling a single loop from several before either is built."""
    b, c = np.asarray(B), np.asarray(C)
    inputs = b.shape[1] if b.ndim == 2 else 1
    outputs = c.shape[0] if c.ndim == 2 else 1
    return int(inputs), int(outputs)


def checked_plant(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike, where: str) -> Plant:
    """The plant of the four matrices (D 0 as a number: zero feedthrough), balanced; a
    `BlockError` naming ``where`` and what is wrong: not square, shapes, too many loops
    (`engine.model.ports.state_space_ports.checked_ports`, a block of several ports' check)."""
    a, b, c, d = checked_ports(A, B, C, D, where)
    return balanced_plant(Plant(a, b, c, d, tuple(f"u{k + 1}" for k in range(d.shape[0]))))


def balanced_plant(p: Plant) -> Plant:
    """The same plant with its states scaled by powers of two (module docstring), as a block of
    several ports is (`engine.model.ports.state_space_ports.balanced_ports`)."""
    return Plant(*balanced_ports(p.A, p.B, p.C, p.D), p.names)


def _solve_posed(matrix: NDArray, rhs: NDArray, what: str) -> NDArray:
    """matrix^-1 rhs, or an `EngineError` when ``matrix`` is (nearly) singular: the loop is not well posed."""
    if matrix.size and 1.0 / np.linalg.cond(matrix) < SINGULAR:
        raise EngineError(f"{what} is singular: the closed loop is not well posed (an algebraic loop)")
    return np.linalg.solve(matrix, rhs) if matrix.size else rhs


def loop_at(p: Plant, i: int) -> Matrices:
    """The single-input single-output loop at input ``i`` with every other loop closed (module docstring)."""
    o = [k for k in range(p.loops) if k != i]
    closing = np.eye(len(o)) + p.D[np.ix_(o, o)]
    # u_o = -(I + D_oo)^-1 (C_o x + D_oi v) = K x + k v
    gains = -_solve_posed(closing, np.hstack([p.C[o], p.D[o, i : i + 1]]), f"{p.names[i]}: I + D of the other loops")
    kx, kv = gains[:, :-1], gains[:, -1]
    a = p.A + p.B[:, o] @ kx
    b = p.B[:, i] + p.B[:, o] @ kv
    c = p.C[i] + p.D[i, o] @ kx
    d = float(p.D[i, i] + p.D[i, o] @ kv)
    return Matrices(a, b, c, d)


def sensitivity(p: Plant) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """(A, B, C, D) of the input sensitivity S = (I + P)^-1 (module docstring)."""
    f = _solve_posed(np.eye(p.loops) + p.D, np.eye(p.loops), "I + D")
    return p.A - p.B @ f @ p.C, p.B @ f, -f @ p.C, f


def closed_loop_poles(p: Plant) -> NDArray[np.complex128]:
    """The eigenvalues of the closed loop's state matrix A - B (I + D)^-1 C."""
    return np.linalg.eigvals(sensitivity(p)[0]) if p.order else np.zeros(0, dtype=complex)

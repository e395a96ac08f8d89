"""A SISO state space x' = A x + B u, y = C x + D u kept as state space: its
response G(s) = C (sI - A)^-1 B + D and dG/ds at any complex points, and its
pole-zero form read from the realization.  Nothing is multiplied out into
polynomial coefficients, which overflow at high order (a plant of order 80
with modes up to 1e3 rad/s has coefficients beyond 1e308).

Coordinates.  The same system in other state coordinates (x scaled by powers of two,
2^+-40) is the same transfer function, and its results must not depend on them: every
model is balanced first (`balanced`: the realization [[A, B], [C, 0]] by LAPACK's gebal,
powers of two on the states alone, so exact), and everything below reads the balanced
matrices.  A pole's backward error is measured in the coordinates the model was given
(`pole_backward_errors`), and a model whose eigenvector basis is still ill-conditioned
after balancing (`ILL_CONDITIONED`) says so (`conditioning_note`).

Evaluation.  When A is diagonalizable with well-conditioned eigenvectors V
(cond(V) <= `MODAL_CONDITION`), G(s) = D + sum r_i / (s - lambda_i) with the
residues r = (C V) * (V^-1 B): a few array operations per batch of points.
Otherwise A is reduced once to upper Hessenberg form H = Q' A Q and each
point solves (sI - H) x = Q' B by Gaussian elimination with partial pivoting,
vectorized over the points (a Hessenberg matrix pivots between two adjacent
rows only); dG/ds = -C Q (sI - H)^-1 x reuses the factors.

Pole-zero form.  Poles: the eigenvalues of A.  Zeros: the transmission zeros,
the finite generalized eigenvalues of the system pencil ([[A, B], [C, D]],
diag(I, 0)).  Its infinite eigenvalues are deflated first, as Emami-Naeini and
Van Dooren do (1982): with D = 0, an orthogonal change of state puts B on the
last state alone (B = beta e_n), and the pencil's determinant is beta times
that of the system (A11, A12, C1, C2) of the other n - 1 states driven by
the last one; repeated while the feedthrough is zero, it ends with D != 0,
whose zeros are the eigenvalues of A - B C / D.  (A QZ on the whole pencil
returns an infinite zero of multiplicity r as r finite values of size about
eps^(-1/r): spurious zeros at high relative degree.)  The gain is matched
to G at frequencies among the roots.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import BlockError
from engine.model.factored import PoleZero

MAX_STATES = 400  # states of one block (the order limit of a factored block, `engine.model.factored`)
ILL_CONDITIONED = 1e12  # cond(V) after balancing beyond which a model's poles are not vouched for
POLE_BACKWARD_ERROR = 1e-10  # a block pole's backward error (`pole_backward_errors`) beyond which a note names it
MODAL_CONDITION = 1e4  # cond(V) up to which the residue sum is used (its error is about cond(V) eps)
NEGLIGIBLE_FEEDTHROUGH = 1e-10  # |D| below this of |C| |B| / |A|: a zero beyond 1e10 |A|, taken as at infinity
WORK_ELEMENTS = 1 << 20  # complex elements of one batch's elimination array (16 MB)


@dataclass(frozen=True)
class Matrices:
    """A (n x n), B (n,), C (n,) and D, real and finite."""

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: float

    @property
    def order(self) -> int:
        return int(self.A.shape[0])


def checked(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike, where: str) -> Matrices:
    """The matrices of a SISO state space (B a column n x 1 or a vector of n, C a row 1 x n or a
    vector, D a number or 1 x 1), or a `BlockError` naming ``where`` and what is wrong."""
    arrays = [real_matrix(x, name, where) for x, name in ((A, "A"), (B, "B"), (C, "C"), (D, "D"))]
    a, b, c, d = arrays
    a = a.reshape(0, 0) if a.size == 0 else a  # no states: a static gain D ([] read as 0 x 0)
    n = a.shape[0] if a.ndim == 2 else -1
    if a.ndim != 2 or a.shape[1] != n:
        raise BlockError(f"{where}: A must be a square matrix, not {shape_text(a)}")
    if n > MAX_STATES:
        raise BlockError(f"{where}: order {n} is beyond the limit of {MAX_STATES} states for one block")
    shapes = (
        (b, "B", {(n,), (n, 1)}, f"{n} x 1"),
        (c, "C", {(n,), (1, n)}, f"1 x {n}"),
        (d, "D", {(), (1,), (1, 1)}, "1 x 1"),
    )
    for x, name, allowed, wanted in shapes:
        if x.shape not in allowed:
            raise BlockError(
                f"{where}: {name} is {shape_text(x)}; with A {n} x {n} it must be {wanted} (one input, one output)"
            )
    return Matrices(a, b.reshape(n), c.reshape(n), float(d.reshape(-1)[0]))


def balanced(m: Matrices) -> tuple[Matrices, NDArray[np.float64]]:
    """The same system in balanced state coordinates, and the state scaling t (powers of
    two: x = t * x_balanced): A_b = A t / t', B_b = B / t, C_b = C t."""
    if m.order == 0:
        return m, np.ones(0)
    t = state_scales(m.A, m.B[:, None], m.C[None, :])
    return Matrices(m.A * t[None, :] / t[:, None], m.B / t, m.C * t, m.D), t


def state_scales(a: NDArray, b: NDArray, c: NDArray) -> NDArray[np.float64]:
    """Powers of two t (x = t * x_balanced) that balance [[A, B], [C, 0]] (B n x m, C m x n,
    n > 0), relative to the first port's scale."""
    from scipy import linalg  # on first use: scipy.linalg costs a fifth of a second of start-up

    n, m = a.shape[0], b.shape[1]
    system = np.zeros((n + m, n + m))
    system[:n, :n], system[:n, n:], system[n:, :n] = a, b, c
    with np.errstate(invalid="ignore"):  # scipy casts the scales to int for a permutation it does not use
        _, (scale, _) = linalg.matrix_balance(system, permute=False, separate=True)
    return scale[:n] / scale[n]


def real_matrix(x: ArrayLike, name: str, where: str) -> NDArray[np.float64]:
    """``x`` as a finite real float array, else a `BlockError` naming ``name`` and ``where``."""
    if np.asarray(x).dtype.kind == "c":  # float() of it would drop the imaginary part
        raise BlockError(f"{where}: {name} must be a matrix of real numbers, not complex")
    try:
        array = np.asarray(x, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise BlockError(f"{where}: {name} must be a matrix of real numbers") from None
    if not np.all(np.isfinite(array)):
        raise BlockError(f"{where}: {name} has a value that is not finite")
    return array


def shape_text(x: NDArray) -> str:
    """An array's shape as a message names it ('3 x 2', 'a number')."""
    return " x ".join(map(str, x.shape)) if x.ndim else "a number"


class Response:
    """G(s) and dG/ds of a state space at complex points (module docstring)."""

    def __init__(self, given: Matrices) -> None:
        """The decompositions of the balanced model (``m``; ``given``: as it came); a
        `BlockError` when their numbers leave the floating-point range."""
        self.given = given
        m, self.scaling = balanced(given)
        self.m = m
        with np.errstate(all="ignore"):
            self.poles, vectors = np.linalg.eig(m.A) if m.order else (np.zeros(0, dtype=complex), np.zeros((0, 0)))
            _finite(self.poles, vectors)
            self.condition = float(np.linalg.cond(vectors)) if m.order else 1.0
            self._vectors = vectors
            self.modal = m.order > 0 and bool(self.condition <= MODAL_CONDITION)
            if self.modal:
                self.residues = (m.C @ vectors) * np.linalg.solve(vectors, m.B.astype(complex))
                self.modal = bool(np.all(np.isfinite(self.residues)))
            if m.order and not self.modal:
                from scipy import linalg  # on first use: scipy.linalg costs a fifth of a second of start-up

                self.h, q = linalg.hessenberg(m.A, calc_q=True)
                self.b, self.c = q.T @ m.B, m.C @ q
                _finite(self.h, self.b, self.c)

    @cached_property
    def pole_errors(self) -> NDArray[np.float64]:
        """Each pole's backward error in the given coordinates (`pole_backward_errors`), on first
        use: only the conditioning note reads it (a loop's margins do not)."""
        with np.errstate(all="ignore"):
            return pole_backward_errors(self.given, self.poles, self._vectors * self.scaling[:, None])

    def __call__(self, s: ArrayLike) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        s = np.asarray(s, dtype=complex)
        flat = s.ravel()
        value, slope = np.full(flat.size, complex(self.m.D)), np.zeros(flat.size, dtype=complex)
        if self.m.order:
            step = max(16, WORK_ELEMENTS // (self.m.order if self.modal else self.m.order**2))
            for start in range(0, flat.size, step):
                part = slice(start, start + step)
                v, d = self._modal(flat[part]) if self.modal else self._hessenberg(flat[part])
                value[part] += v
                slope[part] = d
        return value.reshape(s.shape), slope.reshape(s.shape)

    def _modal(self, s: NDArray) -> tuple[NDArray, NDArray]:
        with np.errstate(all="ignore"):  # a pole hit exactly: not finite, reported by the caller
            inverse = 1.0 / (s[:, None] - self.poles[None, :])
            return inverse @ self.residues, -(inverse * inverse) @ self.residues

    def _hessenberg(self, s: NDArray) -> tuple[NDArray, NDArray]:
        with np.errstate(all="ignore"):
            lu = HessenbergLU(self.h, s)
            x = lu.solve(np.broadcast_to(self.b, (s.size, self.b.size)))
            return x @ self.c, -(lu.solve(x) @ self.c)


def pole_backward_errors(m: Matrices, poles: NDArray, vectors: NDArray) -> NDArray[np.float64]:
    """Each eigenpair's componentwise relative backward error in the coordinates of ``m``:
    max_k |(A v - p v)_k| / (|A| |v| + |p| |v|)_k, the smallest relative change of each entry
    of A that makes (p, v) exact; a diagonal scaling of the states leaves it unchanged."""
    if not poles.size:
        return np.zeros(0)
    with np.errstate(all="ignore"):
        residual = np.abs(m.A @ vectors - vectors * poles[None, :])
        size = np.abs(m.A) @ np.abs(vectors) + np.abs(vectors) * np.abs(poles)[None, :]
        ratio = np.where(residual > 0, residual / size, 0.0)
    return np.nan_to_num(ratio, nan=np.inf).max(axis=0)


def given_response(m: Matrices, s: complex) -> tuple[complex, float]:
    """G(s) in the coordinates of ``m`` (a dense solve, no balancing) and the size of its first-order
    change when every entry of A, B, C, D changes by a relative 1: |y| |A| |x| + |y| |B| + |C| |x| + |D|
    with x = (sI - A)^-1 B, y = C (sI - A)^-1 (a diagonal scaling of the states leaves it unchanged).
    A residual divided by it is a componentwise relative backward error in those coordinates; NaN
    for both when sI - A is exactly singular there."""
    if not m.order:
        return complex(m.D), abs(m.D)
    shifted = s * np.eye(m.order) - m.A
    with np.errstate(all="ignore"):
        try:
            x = np.linalg.solve(shifted, m.B.astype(complex))
            y = np.linalg.solve(shifted.T, m.C.astype(complex))
        except np.linalg.LinAlgError:  # s is an eigenvalue of A exactly, in these coordinates: not measured
            return complex(np.nan, np.nan), np.nan
        size = np.abs(y) @ np.abs(m.A) @ np.abs(x) + np.abs(y) @ np.abs(m.B) + np.abs(m.C) @ np.abs(x) + abs(m.D)
    return complex(m.C @ x + m.D), float(size)


def conditioning_note(response: Response, source: str) -> str | None:
    """One line when the balanced model's eigenvector basis is ill-conditioned
    (`ILL_CONDITIONED`) or a pole's backward error exceeds `POLE_BACKWARD_ERROR`; None otherwise."""
    doubtful = np.flatnonzero(~(response.pole_errors <= POLE_BACKWARD_ERROR))
    if response.condition <= ILL_CONDITIONED and not doubtful.size:
        return None
    named = ", ".join(f"{response.poles[k]:.6g}" for k in doubtful[:3]) + (
        f" and {doubtful.size - 3} more" if doubtful.size > 3 else ""
    )
    what = f"; poles with a backward error above {POLE_BACKWARD_ERROR:g}: {named}" if doubtful.size else ""
    return (
        f"{source}: ill-conditioned even balanced (eigenvector basis conditioned {response.condition:.1e}){what}: "
        "its poles, zeros and the margins near them are not vouched for beyond that conditioning"
    )


class HessenbergLU:
    """LU factors, with partial pivoting, of sI - H for an upper Hessenberg H at many points s
    (rows: points): step k pivots between row k (as reduced so far) and row k + 1."""

    def __init__(self, h: NDArray[np.float64], s: NDArray[np.complex128]) -> None:
        n, points = h.shape[0], s.size
        self.upper = np.zeros((points, n, n), dtype=complex)
        self.factors = np.zeros((points, max(n - 1, 0)), dtype=complex)
        self.swaps = np.zeros((points, max(n - 1, 0)), dtype=bool)
        row = np.broadcast_to(-h[0].astype(complex), (points, n)).copy()
        row[:, 0] += s
        for k in range(n - 1):
            below = np.broadcast_to(-h[k + 1, k:].astype(complex), (points, n - k)).copy()
            below[:, 1] += s
            swap = np.abs(below[:, 0]) > np.abs(row[:, 0])
            pivot = np.where(swap[:, None], below, row)
            other = np.where(swap[:, None], row, below)
            factor = other[:, 0] / pivot[:, 0]
            self.upper[:, k, k:] = pivot
            self.factors[:, k], self.swaps[:, k] = factor, swap
            row = other[:, 1:] - factor[:, None] * pivot[:, 1:]
        if n:
            self.upper[:, n - 1, n - 1] = row[:, 0]

    def solve(self, rhs: NDArray) -> NDArray[np.complex128]:
        """x with (sI - H) x = rhs, point by point (rows)."""
        y = np.array(rhs, dtype=complex)
        n = y.shape[1]
        carry = y[:, 0].copy()
        for k in range(n - 1):
            swap, following = self.swaps[:, k], y[:, k + 1]
            top = np.where(swap, following, carry)
            carry = np.where(swap, carry, following) - self.factors[:, k] * top
            y[:, k] = top
        y[:, n - 1] = carry
        x = np.empty_like(y)
        for k in range(n - 1, -1, -1):
            known = np.einsum("pj,pj->p", self.upper[:, k, k + 1 :], x[:, k + 1 :])
            x[:, k] = (y[:, k] - known) / self.upper[:, k, k]
        return x


def _finite(*arrays: NDArray) -> None:
    if not all(np.all(np.isfinite(x)) for x in arrays):
        raise BlockError("its numbers leave the floating-point range (A's eigenvalues or its reduction overflow)")


def _size(a: NDArray, b: NDArray, c: NDArray) -> float:
    """|C| |B| / |A| (Frobenius; 0 for A = 0): the strictly proper part's size about |s| = |A|."""
    scale = float(np.linalg.norm(a))
    return float(np.linalg.norm(c) * np.linalg.norm(b)) / scale if scale > 0 else 0.0


def transmission_zeros(m: Matrices) -> NDArray[np.complex128] | None:
    """The finite transmission zeros (module docstring); None when G is zero at every
    frequency (B or C vanishes where the deflation reaches it, with no feedthrough)."""
    a, b, c, d = m.A, m.B, m.C, m.D
    while abs(d) <= NEGLIGIBLE_FEEDTHROUGH * _size(a, b, c):  # |B| = 0 or |C| = 0 here: D = 0 exactly
        if a.size == 0 or not np.any(b):
            return None
        q = _householder_to_last(b)
        a, c = q.T @ a @ q, c @ q
        a, b, c, d = a[:-1, :-1], a[:-1, -1], c[:-1], float(c[-1])
    if a.size == 0:
        return np.zeros(0, dtype=complex)
    return np.linalg.eigvals(a - np.outer(b, c) / d).astype(complex)


def _householder_to_last(b: NDArray[np.float64]) -> NDArray[np.float64]:
    """An orthogonal (symmetric) Q with Q' b = +-|b| e_n (b scaled first: no square under- or overflows)."""
    v = b / np.max(np.abs(b))
    v[-1] += np.copysign(np.linalg.norm(v), v[-1] if v[-1] != 0 else 1.0)
    return np.eye(b.size) - 2.0 * np.outer(v, v) / (v @ v)


def pole_zero_form(response: Response) -> PoleZero:
    """gain * prod(s - zeros) / prod(s - poles) of the state space, equal roots cancelled;
    gain 0 (and the poles) when G is zero at every frequency."""
    poles = response.poles.astype(complex)
    with np.errstate(all="ignore"):
        try:
            zeros = transmission_zeros(response.m)
        except np.linalg.LinAlgError:  # an eigenvalue iteration not converging, or its matrix not finite
            zeros = np.full(1, np.nan)
    if zeros is not None:
        _finite(zeros)
    if zeros is None:
        return PoleZero(0.0, np.zeros(0, dtype=complex), poles)
    shape = PoleZero(1.0, zeros, poles)
    at = 1j * _matching_frequencies(np.concatenate([zeros, poles]))
    with np.errstate(all="ignore"):
        ratios = response(at)[0] / shape.evaluate(at)[0]
    ratios = ratios[np.isfinite(ratios)]
    if ratios.size == 0:
        raise BlockError("its gain cannot be matched: the response is not finite among its poles")
    return PoleZero(float(np.median(ratios.real)), zeros, poles).cancelled()


def _matching_frequencies(roots: NDArray[np.complex128]) -> NDArray[np.float64]:
    """Three frequencies about the roots' geometric mean, off any simple ratio of it."""
    sizes = np.abs(roots)
    sizes = sizes[sizes > 0]
    centre = float(np.exp(np.mean(np.log(sizes)))) if sizes.size else 1.0
    return centre * np.array([0.31, 1.13, 3.7])

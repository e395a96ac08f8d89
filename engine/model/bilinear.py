"""The bilinear map between the z-plane and the w-plane.

w = (z - 1)/(z + 1), or scaled by 2/T: w = (2/T)(z - 1)/(z + 1).  On the unit
circle z = exp(j omega T) the w-plane frequency is nu = tan(omega T/2)
(times 2/T when scaled); a w-plane loop is analysed like an s-plane loop in nu.
"""

from __future__ import annotations

import cmath
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import BlockError, GridError
from engine.model.blocks import ExpressionTransfer
from engine.numerics.polynomials import Rational, trim


def _scale(sample_time: float | None) -> float:
    """a in z = (1 + a w)/(1 - a w): 1 unscaled, T/2 scaled by 2/T."""
    return 1.0 if sample_time is None else check_sample_time(sample_time) / 2.0


def check_sample_time(sample_time: float) -> float:
    """The sample time, or a BlockError unless it is finite and > 0."""
    if not (np.isfinite(sample_time) and sample_time > 0):
        raise BlockError(f"sample time must be finite and > 0, not {sample_time!r}")
    return sample_time


def z_to_w(h: Rational, sample_time: float | None = None) -> Rational:
    """H(z) -> H(w) by substituting z = (1 + a w)/(1 - a w)."""
    a = _scale(sample_time)
    n = max(h.num.size, h.den.size) - 1
    plus, minus = np.array([a, 1.0]), np.array([-a, 1.0])

    def substitute(coefficients: NDArray) -> NDArray:
        total = np.zeros(1)
        for k, c in enumerate(coefficients[::-1]):  # c multiplies z^k
            total = np.polyadd(total, c * np.polymul(_power(plus, k), _power(minus, n - k)))
        return trim(total)

    return Rational(substitute(h.num), substitute(h.den))


def _power(p: NDArray, k: int) -> NDArray:
    result = np.ones(1)
    for _ in range(k):
        result = np.polymul(result, p)
    return result


def w_frequency(omega: ArrayLike, sample_time: float, scaled: bool = False) -> NDArray[np.float64]:
    """w-plane frequency nu of the real frequency omega (rad/s), below Nyquist."""
    omega = np.asarray(omega, dtype=float)
    nu = np.tan(omega * sample_time / 2.0)
    return nu * (2.0 / sample_time) if scaled else nu


def real_frequency(nu: ArrayLike, sample_time: float, scaled: bool = False) -> NDArray[np.float64]:
    """Real frequency omega (rad/s) of the w-plane frequency nu."""
    nu = np.asarray(nu, dtype=float)
    if scaled:
        nu = nu * sample_time / 2.0
    return 2.0 * np.arctan(nu) / sample_time


Z_OF_W = "((1+w)/(1-w))"


def realization_in_z(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, ...]:
    """A realization in w as one in z, w = (z - 1)/(z + 1): with M = (I - A)^-1, A_z = (I + A) M,
    B_z = sqrt(2) M B, C_z = sqrt(2) C M, D_z = D + C M B (= H(w = 1), z = inf); stacked
    realizations (a leading axis of samples) alike."""
    eye = np.eye(A.shape[-1])
    M = np.linalg.inv(eye - A)
    root2 = math.sqrt(2.0)
    return (eye + A) @ M, root2 * M @ B, root2 * C @ M, D + C @ M @ B


def z_of_w(points: ArrayLike) -> NDArray[np.complex128]:
    """A sampled loop's w-plane roots in z = (1 + w)/(1 - w) (w = 1: z = inf)."""
    w = np.asarray(points, dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(w == 1, complex(np.inf), (1 + w) / (1 - w))


def w_of_z(points: ArrayLike) -> NDArray[np.complex128]:
    """Points in z in a sampled loop's w-plane, w = (z - 1)/(z + 1), the inverse of `z_of_w` (z = -1: w = inf)."""
    z = np.asarray(points, dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(z == -1, complex(np.inf), (z - 1) / (z + 1))


def s_of_z(z: ArrayLike, sample_time: float) -> NDArray[np.complex128]:
    """The s-plane equivalent s = ln(z)/T of points in z (the one place it is computed): the
    principal branch, |Im s| <= pi/T; z = 0 is s = -inf (infinitely fast)."""
    z = np.asarray(z, dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(z) / sample_time


def z_of_s(s: ArrayLike, sample_time: float) -> NDArray[np.complex128]:
    """The point z = exp(s T) of s-plane points (`s_of_z` undone)."""
    return np.exp(np.asarray(s, dtype=complex) * sample_time)


def nyquist_frequency(sample_time: float) -> float:
    """pi/T (rad/s): a loop in z is evaluated up to it (z = -1, where its Nyquist gain margin
    is read) and refused above (`refuse_above_nyquist`); a session's grid ends below it."""
    return math.pi / sample_time


def refuse_above_nyquist(omega: ArrayLike, sample_time: float) -> None:
    """The one Nyquist guard: a GridError naming the first frequency above pi/T (there
    tan(omega T/2) wraps round: an alias, silently)."""
    omega = np.asarray(omega, dtype=float)
    above = np.flatnonzero(omega > nyquist_frequency(sample_time))
    if above.size:
        raise GridError(
            f"{omega.flat[above[0]]:.6g} rad/s is above the Nyquist frequency pi/T = "
            f"{nyquist_frequency(sample_time):.6g} rad/s of a loop sampled every {sample_time:g} s"
        )


def damping(root: complex, sample_time: float | None = None) -> tuple[float, float]:
    """(zeta, wn) of a root in s, or in z (``sample_time``: of its s-plane equivalent
    `s_of_z`; z = 0 is infinitely fast, damping 1); a root at 0 in s: damping 1, wn 0."""
    s = complex(root) if sample_time is None else complex(s_of_z(root, sample_time))
    if not cmath.isfinite(s):
        return 1.0, math.inf
    wn = abs(s)
    return (-s.real / wn if wn > 0 else 1.0), wn


def s_equivalent(w: complex, sample_time: float) -> tuple[complex, float, float]:
    """A sampled loop's w-plane root as (z, damping, natural frequency) of its s-plane equivalent
    s = ln(z)/T (`s_of_z`), z = (1 + w)/(1 - w); z = 0 or inf: infinitely fast, damping 1."""
    z = complex(z_of_w(w))
    if not cmath.isfinite(z):
        return z, 1.0, math.inf
    return (z, *damping(z, sample_time))


def realization_in_w(A: NDArray, B: NDArray, C: NDArray, D: NDArray) -> tuple[NDArray, ...]:
    """A realization in z as one in w, z = (1 + w)/(1 - w) (`realization_in_z` undone): with
    N = (I + A)^-1, A_w = N (A - I), B_w = sqrt(2) N B, C_w = sqrt(2) C N, D_w = D - C N B.
    A pole at z = -1 (on the unit circle at the Nyquist frequency) has no w-plane form."""
    identity = np.eye(A.shape[0])
    if A.shape[0] and np.min(np.abs(np.linalg.eigvals(A) + 1.0)) <= 1e-12 * max(1.0, np.abs(A).max()):
        raise BlockError("a pole at z = -1 (on the unit circle at the Nyquist frequency): the loop has no value there")
    N = np.linalg.inv(identity + A)
    root2 = math.sqrt(2.0)
    return N @ (A - identity), root2 * N @ B, root2 * C @ N, D - C @ N @ B


def z_transfer(transfer: ExpressionTransfer) -> ExpressionTransfer:
    """A sampled network's entry as it was typed, in z (`sampled_network` wrote each z as `Z_OF_W`)."""
    return ExpressionTransfer(transfer.text.replace(Z_OF_W, "z"), "z")

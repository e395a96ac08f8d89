"""The bilinear map between the z-plane and the w-plane.

w = (z - 1)/(z + 1), or scaled by 2/T: w = (2/T)(z - 1)/(z + 1).  On the unit
circle z = exp(j omega T) the w-plane frequency is nu = tan(omega T/2)
(times 2/T when scaled); a w-plane loop is analysed like an s-plane loop in nu.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import BlockError
from engine.model.blocks import ExpressionTransfer, StateSpaceTransfer
from engine.model.expressions import substituted
from engine.model.network import Network
from engine.numerics.polynomials import Rational, degree, trim


def _scale(sample_time: float | None) -> float:
    """a in z = (1 + a w)/(1 - a w): 1 unscaled, T/2 scaled by 2/T."""
    if sample_time is None:
        return 1.0
    if not (np.isfinite(sample_time) and sample_time > 0):
        raise BlockError(f"sample time must be finite and > 0, not {sample_time!r}")
    return sample_time / 2.0


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
    B_z = sqrt(2) M B, C_z = sqrt(2) C M, D_z = D + C M B (= H(w = 1), z = inf)."""
    M = np.linalg.inv(np.eye(A.shape[0]) - A)
    root2 = math.sqrt(2.0)
    return (np.eye(A.shape[0]) + A) @ M, root2 * M @ B, root2 * C @ M, D + C @ M @ B


def z_of_w(points: ArrayLike) -> NDArray[np.complex128]:
    """A sampled loop's w-plane roots in z = (1 + w)/(1 - w) (w = 1: z = inf)."""
    w = np.asarray(points, dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(w == 1, complex(np.inf), (1 + w) / (1 - w))


def s_equivalent(w: complex, sample_time: float) -> tuple[complex, float, float]:
    """A sampled loop's w-plane root as (z, damping, natural frequency) of its s-plane equivalent
    s = ln(z)/T, z = (1 + w)/(1 - w); z = 0 or inf: infinitely fast, damping 1."""
    z = complex(z_of_w(w))
    if z == 0 or not cmath.isfinite(z):
        return z, 1.0, math.inf
    s = cmath.log(z) / sample_time
    wn = abs(s)
    return z, (-s.real / wn if wn else 1.0), wn


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


GENERIC = 0.7371  # a parameter value no degree depends on (a block's degrees are read at it)


def _check_causal(transfer: ExpressionTransfer, label: str) -> None:
    """A block in z has no more zeros than poles: else its output leads its input (z^2/(z - 0.5)),
    which no computer can run, though its w-plane form is proper."""
    r = transfer.rational(dict.fromkeys(transfer.parameters, GENERIC))
    zeros, poles = degree(r.num), degree(r.den)
    if zeros > poles:
        raise BlockError(
            f"{label}: {transfer.text} has more zeros than poles in z ({zeros} over {poles}): not causal "
            "(its output would lead its input by a sample)"
        )


def sampled_network(network: Network, sample_time: float) -> Network:
    """A network of expressions in z as the sampled loop the engine analyzes: every z written
    (1 + w)/(1 - w), variable w, with its sample time (`Network.sampled`).  The factored forms
    cancel the (1 - w) this leaves exactly (`engine.model.factored`); no polynomial is expanded."""
    _scale(sample_time)
    entries = []
    for e in network.entries:
        t = e.transfer
        if isinstance(t, StateSpaceTransfer):  # x[k+1] = A x[k] + B u[k]: in w, kept as state space
            try:
                w_form = StateSpaceTransfer(*realization_in_w(*t.realization()), source=f"{t.source}, in z")
            except BlockError as exc:
                raise BlockError(f"{e.label}: {exc}") from None
            entries.append(replace(e, transfer=w_form))
            continue
        if not isinstance(t, ExpressionTransfer) or t.expression.variable != "z":
            raise BlockError(
                f"{e.label}: a loop in z takes expressions in z (polynomial, factored or typed) and state spaces, "
                f"not a {type(t).__name__} (discretize a continuous block first)"
            )
        if "w" in t.parameters:
            raise BlockError(f"{e.label}: a loop in z names w, the variable of its w-plane form: rename the parameter")
        _check_causal(t, e.label)
        entries.append(replace(e, transfer=ExpressionTransfer(substituted(t.text, "z", Z_OF_W), "w")))
    return Network(network.signals, network.inputs, tuple(entries), "w", sample_time)

"""Continuous blocks discretized for a loop in z with sample time T: zero-order hold
(exact, with the block's delay as whole and fractional samples: the modified z-transform,
computed from the state space as Franklin and Powell do), Tustin (with optional
prewarping at a frequency, where the discrete response then equals the continuous one
exactly), and matched pole-zero.  Transfer functions are (numerator, denominator) in
descending powers: of s going in, of z coming out."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import BlockError
from engine.model.bilinear import z_of_s
from engine.model.factor_text import root_factors
from engine.model.factored import MAX_ORDER, PoleZero, pole_zero

Polynomials = tuple[NDArray[np.float64], NDArray[np.float64]]


def _checked(num: ArrayLike, den: ArrayLike, sample_time: float) -> Polynomials:
    n = np.trim_zeros(np.atleast_1d(np.asarray(num, float)), "f")
    d = np.trim_zeros(np.atleast_1d(np.asarray(den, float)), "f")
    if not (math.isfinite(sample_time) and sample_time > 0):
        raise BlockError(f"the sample time must be finite and > 0, not {sample_time!r}")
    if d.size == 0 or not np.all(np.isfinite(n)) or not np.all(np.isfinite(d)):
        raise BlockError("a block to discretize needs finite coefficients and a nonzero denominator")
    if n.size > d.size:
        raise BlockError("an improper block (more zeros than poles) cannot be discretized")
    return (n if n.size else np.zeros(1)), d


def zoh(num: ArrayLike, den: ArrayLike, sample_time: float, delay: float = 0.0) -> Polynomials:
    """The zero-order-hold equivalent of num/den with an input delay (seconds, >= 0):
    G(z) = (1 - 1/z) Z{exp(-delay s) G(s)/s}, exact (the delay as N whole samples and a
    fraction: Franklin, Powell and Workman's Gamma_0, Gamma_1)."""
    from scipy.linalg import expm
    from scipy.signal import tf2ss

    n, d = _checked(num, den, sample_time)
    if not (math.isfinite(delay) and delay >= 0):
        raise BlockError(f"the delay must be finite and >= 0, not {delay!r}")
    whole = math.floor(delay / sample_time + 1e-12)
    if whole > MAX_ORDER:  # z^-N is a block of order N
        raise BlockError(
            f"a delay of {delay:g} s is {delay / sample_time:.6g} samples of {sample_time:g} s: more than {MAX_ORDER} "
            "(one block's order is bounded)"
        )
    fraction = max(delay - whole * sample_time, 0.0)
    if fraction <= 1e-12 * sample_time:
        fraction = 0.0
    A, B, C, D = tf2ss(n, d)
    size = A.shape[0]
    phi, gamma0 = _hold(A, B, sample_time - fraction, expm)
    if fraction:
        step, gamma1 = _hold(A, B, fraction, expm)
        gamma1 = phi @ gamma1
        phi = phi @ step
    else:
        gamma1 = np.zeros_like(B)
    # x[k+1] = phi x[k] + gamma1 u[k-1] + gamma0 u[k]; y[k] = C x[k] + D (u[k] or u[k-1] with a fraction)
    z_num, z_den = _transfer(phi, gamma0, gamma1, C, D, size, bool(fraction))
    z_den = np.concatenate([z_den, np.zeros(whole)])  # z^-whole
    return _normalized(z_num, z_den)


def _hold(A: NDArray, B: NDArray, span: float, expm) -> tuple[NDArray, NDArray]:
    """(exp(A span), integral_0^span exp(A eta) d eta B) from one exponential."""
    size, inputs = A.shape[0], B.shape[1]
    block = np.zeros((size + inputs, size + inputs))
    block[:size, :size], block[:size, size:] = A * span, B * span
    e = expm(block)
    return e[:size, :size], e[:size, size:]


def _transfer(phi, gamma0, gamma1, C, D, size: int, fraction: bool) -> Polynomials:
    """The transfer function of x+ = phi x + gamma0 u + gamma1 u_prev, y = C x + D u(_prev):
    the previous input is a state of its own."""
    from scipy.signal import ss2tf

    A = np.zeros((size + 1, size + 1))
    A[:size, :size], A[:size, size:] = phi, gamma1
    B = np.zeros((size + 1, 1))
    B[:size], B[size, 0] = gamma0, 1.0
    C2 = np.zeros((1, size + 1))
    C2[0, :size] = C
    D2 = np.array([[0.0]]) if fraction else np.asarray(D, float).reshape(1, 1)
    if fraction:
        C2[0, size] = float(np.asarray(D).ravel()[0])
    num, den = ss2tf(A, B, C2, D2)
    return np.asarray(num[0], float), np.asarray(den, float)


def tustin(num: ArrayLike, den: ArrayLike, sample_time: float, prewarp: float | None = None) -> Polynomials:
    """Tustin's bilinear equivalent, s = k (z - 1)/(z + 1) with k = 2/T, or prewarped
    (k = w/tan(w T/2): the discrete response equals the continuous one at w, rad/s,
    below the Nyquist frequency)."""
    n, d = _checked(num, den, sample_time)
    k = 2.0 / sample_time
    if prewarp is not None:
        if not (0 < prewarp < math.pi / sample_time):
            raise BlockError(f"the prewarp frequency must lie in (0, pi/T) = (0, {math.pi / sample_time:.6g}) rad/s")
        k = prewarp / math.tan(prewarp * sample_time / 2.0)
    order = d.size - 1
    plus, minus = np.array([1.0, 1.0]), np.array([1.0, -1.0])

    def substitute(c: NDArray) -> NDArray:
        total = np.zeros(1)
        degree = c.size - 1
        for i, coefficient in enumerate(c):  # coefficient of s^(degree - i)
            power = degree - i
            term = coefficient * k**power * (np.poly1d(minus) ** power).coeffs
            total = np.polyadd(total, np.polymul(term, (np.poly1d(plus) ** (order - power)).coeffs))
        return total

    return _normalized(substitute(n), substitute(d))


def matched(num: ArrayLike, den: ArrayLike, sample_time: float) -> Polynomials:
    """Matched pole-zero: every finite pole and zero p goes to exp(p T), each zero at
    infinity but one to z = -1, the gain matched at DC (at w = pi/(10 T) when a pole or
    zero sits at the origin)."""
    n, d = _checked(num, den, sample_time)
    zeros, poles = np.roots(n), np.roots(d)
    z_zeros = np.exp(zeros * sample_time)
    z_poles = np.exp(poles * sample_time)
    extra = max(poles.size - zeros.size - 1, 0)
    z_zeros = np.concatenate([z_zeros, -np.ones(extra)])
    z_num, z_den = np.atleast_1d(np.real(np.poly(z_zeros))), np.atleast_1d(np.real(np.poly(z_poles)))
    at_origin = np.any(np.abs(np.concatenate([zeros, poles])) < 1e-12)
    w = math.pi / (10 * sample_time) if at_origin else 0.0
    continuous = np.polyval(n, 1j * w) / np.polyval(d, 1j * w)
    point = np.exp(1j * w * sample_time)
    discrete = np.polyval(z_num, point) / np.polyval(z_den, point)
    return _normalized(z_num * abs(continuous) / abs(discrete) * np.sign(n[0] / d[0]), z_den)


def _normalized(num: NDArray, den: NDArray) -> Polynomials:
    """Both divided by the denominator's leading coefficient, leading zeros trimmed."""
    den = np.trim_zeros(np.asarray(den, float), "f")
    num = np.asarray(num, float)
    scale = den[0]
    num = np.trim_zeros(num, "f") if np.any(num) else np.zeros(1)
    common = min(_trailing_zeros(num), _trailing_zeros(den))  # z factors both share (an unused state)
    if common:
        num, den = num[:-common], den[:-common]
    return num / scale, den / scale


def _trailing_zeros(c: NDArray) -> int:
    nonzero = np.flatnonzero(c)
    return 0 if nonzero.size == 0 else c.size - 1 - int(nonzero[-1])


METHODS = ("zoh", "tustin", "matched")


def discretized_text(
    text: str, sample_time: float, method: str = "zoh", delay: float = 0.0, prewarp: float | None = None
) -> str:
    """A continuous block (an expression in s, numbers only) discretized by ``method`` as an
    expression in z: its gain and its zeros' and poles' factors (`z_factors`; integrators at
    z = 1 exactly); ``delay`` (s) with the hold only (zoh), ``prewarp`` (rad/s) with Tustin only."""
    from engine.model.blocks import ExpressionTransfer

    if method not in METHODS:
        raise BlockError(f"discretized by {method!r}: the methods are {', '.join(METHODS)}")
    if delay and method != "zoh":
        raise BlockError(f"a delay is discretized with its hold (zoh), not by {method}")
    if prewarp is not None and method != "tustin":
        raise BlockError(f"prewarping is Tustin's, not {method}'s")
    transfer = ExpressionTransfer(text, "s")
    if transfer.parameters:
        raise BlockError(
            f"{text!r} names {', '.join(transfer.parameters)}: a block discretized on the way in has numbers only"
        )
    r = transfer.rational({})
    try:
        with np.errstate(all="ignore"):
            if method == "zoh":
                num, den = zoh(r.num, r.den, sample_time, delay)
            elif method == "tustin":
                num, den = tustin(r.num, r.den, sample_time, prewarp)
            else:
                num, den = matched(r.num, r.den, sample_time)
            finite = bool(np.all(np.isfinite(num)) and np.all(np.isfinite(den)) and den[0] != 0)
            if finite:
                at_origin = (_trailing_zeros(np.trim_zeros(r.num, "f")), _trailing_zeros(np.trim_zeros(r.den, "f")))
                zeros, poles = (_at_one(np.roots(c), k) for c, k in zip((num, den), at_origin))
                gain = float(num[0] / den[0])
                if method == "zoh":
                    poles = _held_poles(pole_zero(transfer.expression, {}).poles, sample_time, den.size - 1)
                    gain = _kept_dc_gain(r.num, r.den, zeros, poles, gain)
                finite = bool(np.isfinite(gain))
    except (np.linalg.LinAlgError, ArithmeticError):
        finite = False
    if not finite:
        raise BlockError(_beyond_precision(text, method, r.den, sample_time, delay))
    return f"({gain!r})*{z_factors(zeros)}/{z_factors(poles)}"


def _held_poles(continuous: NDArray, sample_time: float, degree: int) -> NDArray[np.complex128]:
    """A hold's poles exactly: exp(p T) of each continuous pole (the roots of its expanded
    denominator in z lose digits where they cluster near z = 1: 5.8e-6 in a DC gain with
    poles within 1e-3 of 1), and z = 0 for the delay's samples and its fraction's state."""
    held = z_of_s(continuous, sample_time)
    held[continuous == 0] = 1.0
    return np.concatenate([held, np.zeros(max(degree - held.size, 0), dtype=complex)])


def _kept_dc_gain(num: NDArray, den: NDArray, zeros: NDArray, poles: NDArray, gain: float) -> float:
    """The gain for which the hold keeps G(0) = num(0)/den(0) at z = 1 (``gain`` as it is when
    G(0) is 0 or infinite)."""
    n0, d0 = float(np.polyval(num, 0.0)), float(np.polyval(den, 0.0))
    if n0 == 0 or d0 == 0:
        return gain
    unit = PoleZero(1.0, zeros, poles).evaluate(np.ones(1, dtype=complex))[0][0]
    return float((n0 / d0 / unit).real)


def _beyond_precision(text: str, method: str, den: NDArray, sample_time: float, delay: float) -> str:
    """Why a discretization left double precision: the fastest pole and the delay in samples."""
    with np.errstate(all="ignore"):
        roots = np.roots(np.trim_zeros(den, "f"))
        fastest = float(np.max(np.abs(roots))) * sample_time if roots.size else 0.0
        samples = f", delay / T = {delay / sample_time:.3g}" if delay else ""
    return (
        f"{text!r} discretized by {method} at T = {sample_time:g} s cannot be computed in double precision "
        f"(fastest pole x T = {fastest:.3g}{samples}); choose another sample time"
    )


def _at_one(roots: NDArray, count: int) -> NDArray:
    """The ``count`` roots nearest z = 1 set to 1 exactly: integrators (or differentiators) of the
    continuous block, which every method maps to z = 1 and which rounding moves off it by ~eps."""
    roots = np.asarray(roots, dtype=complex).copy()
    if count:
        nearest = np.argsort(np.abs(roots - 1.0))[:count]
        roots[nearest] = 1.0
    return roots


def z_factors(roots: NDArray) -> str:
    """prod (z - r) as text (`engine.model.factor_text.root_factors`: a conjugate pair as one real
    quadratic, real roots exact)."""
    factors = root_factors(roots, "z")
    return "(" + "*".join(factors) + ")" if factors else "1"

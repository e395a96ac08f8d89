"""The bilinear map between the z-plane and the w-plane.

w = (z - 1)/(z + 1), or scaled by 2/T: w = (2/T)(z - 1)/(z + 1).  On the unit
circle z = exp(j omega T) the w-plane frequency is nu = tan(omega T/2)
(times 2/T when scaled); a w-plane loop is analysed like an s-plane loop in nu.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import BlockError
from engine.numerics.polynomials import Rational, trim


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

"""Ratios of real polynomials in one variable, coefficients in descending powers.

Arithmetic does not cancel common factors; `Rational.minimal` does, on request.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


def trim(coefficients: ArrayLike) -> NDArray[np.float64]:
    """Drop leading zeros of a descending coefficient vector (keeps at least one)."""
    c = np.atleast_1d(np.asarray(coefficients, dtype=float))
    if c[0] != 0.0:
        return c
    nonzero = np.flatnonzero(c)
    return c[nonzero[0] :] if nonzero.size else np.zeros(1)


def _convolve(a: NDArray, b: NDArray) -> NDArray:
    """np.convolve, in plain Python for the short polynomials of blocks (much faster)."""
    if a.size * b.size > 16:
        return np.convolve(a, b)
    out = [0.0] * (a.size + b.size - 1)
    for i, x in enumerate(a.tolist()):
        for j, y in enumerate(b.tolist()):
            out[i + j] += x * y
    return np.array(out)


def _add(a: NDArray, b: NDArray) -> NDArray:
    if a.size == b.size:
        return a + b
    if a.size < b.size:
        a, b = b, a
    out = a.copy()
    out[a.size - b.size :] += b
    return out


def degree(coefficients: NDArray[np.float64]) -> int:
    """Degree of a trimmed polynomial; -1 for the zero polynomial."""
    c = trim(coefficients)
    return -1 if (c.size == 1 and c[0] == 0.0) else c.size - 1


@dataclass(frozen=True)
class Rational:
    """num(x)/den(x) with descending coefficients."""

    num: NDArray[np.float64]
    den: NDArray[np.float64]

    @staticmethod
    def constant(value: float) -> Rational:
        return Rational(np.array([float(value)]), np.array([1.0]))

    @staticmethod
    def variable() -> Rational:
        return Rational(np.array([1.0, 0.0]), np.array([1.0]))

    def __add__(self, other: Rational) -> Rational:
        if np.array_equal(self.den, other.den):
            return Rational(trim(_add(self.num, other.num)), self.den)
        return Rational(
            trim(_add(_convolve(self.num, other.den), _convolve(other.num, self.den))),
            trim(_convolve(self.den, other.den)),
        )

    def __neg__(self) -> Rational:
        return Rational(-self.num, self.den)

    def __sub__(self, other: Rational) -> Rational:
        return self + (-other)

    def __mul__(self, other: Rational) -> Rational:
        return Rational(trim(_convolve(self.num, other.num)), trim(_convolve(self.den, other.den)))

    def reciprocal(self) -> Rational:
        return Rational(self.den, self.num)

    def __truediv__(self, other: Rational) -> Rational:
        return self * other.reciprocal()

    def __pow__(self, exponent: int) -> Rational:
        base = self if exponent >= 0 else self.reciprocal()
        result = Rational.constant(1.0)
        for _ in range(abs(exponent)):
            result = result * base
        return result

    @property
    def is_zero_denominator(self) -> bool:
        return degree(self.den) < 0

    @property
    def relative_degree(self) -> int:
        """deg(den) - deg(num); negative means improper."""
        return degree(self.den) - degree(self.num)

    def normalized(self) -> Rational:
        """Scale so the denominator is monic."""
        lead = self.den[0]
        return Rational(self.num / lead, self.den / lead)

    def __call__(self, x: ArrayLike) -> NDArray[np.complex128]:
        x = np.asarray(x)
        return np.polyval(self.num, x) / np.polyval(self.den, x)

"""The one evaluation of a pole-zero product, g prod(x - z_i) / prod(x - p_j), at any points:
its value, its logarithmic derivative u = sum 1/(x - z_i) - sum 1/(x - p_j) and u' = du/dx.

Every caller reads it here: the margins' fast evaluator on the j omega axis
(`engine.loop.pole_zero`), the grid-free searches' levels (`engine.margins.pole_zero`, one
loop or many samples at once), the characteristic equation at complex points
(`engine.closed_loop.characteristic`), the locus's breakaway points, an expression's
factored form (`engine.model.factored`) and the sums' zeros.

The zeros and the poles are sorted and paired in that order (m = min of their counts):
rows m zeros, m poles, then the unpaired roots of the more numerous kind.  With q = x - root
and r = 1/q, the value is g prod(q_zero r_pole) over the pairs times the unpaired factors
(q for zeros, r for poles): no partial product over- or underflows where a product of many
zeros and then of many poles can, and no complex division is made (it is slow).  A pair's
1/(x - z) - 1/(x - p) is (z - p) r_z r_p and its derivative -(z - p) r_z r_p (r_z + r_p):
no cancellation where a zero nearly cancels its pole, or far above both.  Where the value
still leaves the floating-point range (or underflows to 0 without an exact zero), it is
recomputed by logarithms, g exp(sum log q_zero - sum log q_pole).

Roots are stored with the root axis first; the points ``x`` broadcast against the rest, so
one loop (roots (n,) at points (F,)) and many samples at their own points (roots (n, K) at
points (K,): `PairedProduct._columns`, taken a pass of points at a time) share the arithmetic.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

CHUNK = 1 << 16  # root-point pairs a pass holds (1 MB of complex work array each)


class ProductTerms(NamedTuple):
    """The product's value, u = d log / dx and du/dx (None unless asked) at the points, and the
    sum of the moduli of u's terms as they are formed, |z - p| |r_z| |r_p| a pair and |r| an
    unpaired root (None unless asked: the scale of u's rounding)."""

    value: NDArray[np.complex128]
    slope: NDArray[np.complex128]
    curvature: NDArray[np.complex128] | None
    size: NDArray[np.float64] | None


class PairedProduct:
    """g prod(x - zeros) / prod(x - poles), zeros and poles paired (module docstring).

    ``zeros`` and ``poles`` are 1-D (one product) or 2-D with a leading axis of samples
    (every sample as many of each); ``gain`` is a number or one per sample."""

    def __init__(self, gain: complex | NDArray, zeros: NDArray, poles: NDArray):
        zeros, poles = (
            np.sort_complex(np.asarray(zeros, dtype=complex)),
            np.sort_complex(np.asarray(poles, dtype=complex)),
        )
        self.gain = gain
        self.zeros, self.poles = zeros, poles
        self.paired = m = min(zeros.shape[-1], poles.shape[-1])
        self.extra_zeros = zeros.shape[-1] > poles.shape[-1]
        rows = np.concatenate([zeros[..., :m], poles[..., :m], zeros[..., m:], poles[..., m:]], axis=-1)
        self.roots = rows.T if rows.ndim == 2 else rows[:, None]  # root axis first; one product: a column
        self.gaps = (zeros[..., :m] - poles[..., :m]).T
        unpaired = self.roots.shape[0] - 2 * m
        self.signs = np.concatenate([np.ones(m), -np.ones(m), np.full(unpaired, 1.0 if self.extra_zeros else -1.0)])

    def _columns(self, samples: NDArray[np.intp]) -> PairedProduct:
        """The product of each listed sample, one per point (roots (n, K) for K points): what
        `terms` evaluates (the paired rows; ``zeros`` and ``poles`` stay the samples', not gathered)."""
        picked = PairedProduct.__new__(PairedProduct)
        picked.gain = np.take(self.gain, samples)
        picked.zeros, picked.poles = self.zeros, self.poles
        picked.paired, picked.extra_zeros, picked.signs = self.paired, self.extra_zeros, self.signs
        picked.roots, picked.gaps = np.take(self.roots, samples, axis=1), np.take(self.gaps, samples, axis=1)
        return picked

    def terms(
        self, x: NDArray, curvature: bool = False, size: bool = False, samples: NDArray[np.intp] | None = None
    ) -> ProductTerms:
        """Value and u at ``x`` (and du/dx, the size of u's terms when asked), no warnings (module
        docstring).  A product of many samples: point k is sample ``samples[k]``'s (default: point
        k is sample k).  Many points go in passes of at most `CHUNK` root-point pairs, so the
        memory a call holds is bounded whatever the number of points."""
        if samples is None and self.roots.shape[1] > 1:
            samples = np.arange(np.size(x))
        step = max(16, CHUNK // max(1, self.roots.shape[0]))
        if samples is None:
            if np.ndim(x) != 1 or x.size <= step:
                return self._terms(x, curvature, size)
            pieces = [self._terms(x[a : a + step], curvature, size) for a in range(0, x.size, step)]
        else:
            pieces = [
                self._columns(samples[a : a + step])._terms(x[a : a + step], curvature, size)
                for a in range(0, max(x.size, 1), step)  # one pass at least: no points, empty terms
            ]
        return ProductTerms(*(None if part[0] is None else np.concatenate(part) for part in zip(*pieces)))

    def _terms(self, x: NDArray, curvature: bool, size: bool) -> ProductTerms:
        """`terms` in one pass."""
        m, n = self.paired, self.roots.shape[0]
        with np.errstate(all="ignore"):
            q = x - self.roots
            r = 1.0 / q
            value = self.gain * np.multiply.reduce(q[:m] * r[m : 2 * m], axis=0)
            if n > 2 * m:
                value = value * np.multiply.reduce(q[2 * m :] if self.extra_zeros else r[2 * m :], axis=0)
            pair = r[:m] * r[m : 2 * m]
            slope = self.gaps @ pair if self.gaps.ndim == 1 and m else _weighted(self.gaps, pair)
            second = -_weighted(self.gaps, pair * (r[:m] + r[m : 2 * m])) if curvature else None
            if n > 2 * m:
                rest = r[2 * m :]
                slope = slope + _weighted(self.signs[2 * m :], rest)
                second = None if second is None else second - _weighted(self.signs[2 * m :], rest * rest)
            if not (np.isfinite(value).all() and value.all()):  # two reductions on the fast path
                value = self._in_range(value, q)
            spread = _spread(self.gaps, np.abs(r), m) if size else None
        return ProductTerms(value, slope, second, spread)

    def _in_range(self, value: NDArray, q: NDArray) -> NDArray:
        """``value`` recomputed by logarithms where it left the floating-point range."""
        lost = ~np.isfinite(value) | (value == 0)
        lost &= np.all(q != 0, axis=0) & np.all(np.isfinite(q), axis=0)  # an exact zero or pole stays
        gain = np.broadcast_to(self.gain, value.shape)
        lost &= gain != 0
        if not lost.any():
            return value
        logs = self.signs @ np.log(q[:, lost].reshape(q.shape[0], -1).astype(complex))
        value = np.array(value, dtype=complex, copy=True)
        g = gain[lost]
        value[lost] = g / np.abs(g) * np.exp(logs + np.log(np.abs(g)))
        return value


def reciprocal_sum(x: NDArray, roots: NDArray) -> NDArray[np.complex128]:
    """sum 1/(x - root) over ``roots`` at each point ``x`` (a polynomial's p'/p)."""
    with np.errstate(all="ignore"):
        return np.sum(1.0 / (np.asarray(x)[..., None] - roots), axis=-1)


def log_modulus_sum(x: NDArray, roots: NDArray) -> NDArray[np.float64]:
    """sum log |x - root| over ``roots`` at each point ``x`` (a polynomial's log |p|)."""
    with np.errstate(all="ignore"):
        return np.sum(np.log(np.abs(np.asarray(x)[..., None] - roots)), axis=-1)


def _spread(gaps: NDArray, moduli: NDArray, m: int) -> NDArray[np.float64]:
    """|z - p| |r_z| |r_p| over the pairs plus |r| over the unpaired roots (`ProductTerms.size`)."""
    paired = _weighted(np.abs(gaps), moduli[:m] * moduli[m : 2 * m]).real
    return paired + moduli[2 * m :].sum(axis=0)


def _weighted(weights: NDArray, rows: NDArray) -> NDArray:
    """sum_i weights_i rows_i: a matrix product for one product, elementwise for samples."""
    if weights.shape[0] == 0:
        return np.zeros(rows.shape[1:], dtype=complex)
    if weights.ndim == 1:
        return weights @ rows
    out = weights[0] * rows[0]  # np.sum(weights * rows, axis=0)'s additions in its order, without the (n, K) product
    for weight, row in zip(weights[1:], rows[1:]):
        out += weight * row
    return out

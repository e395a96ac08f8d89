"""Zeros of sums of simple fractions and of small polynomials, for the
margin search of a loop in pole-zero form (`engine.margins.pole_zero.search`).

A sum f(x) = sum a_k / (x - t_k) whose terms are closed under conjugation
((t, a) and (conj t, conj a) both in it) is c^T (x I - L)^-1 b for a real
block-diagonal L: a 2x2 block [[Re t, -Im t], [Im t, Re t]] per conjugate
pair with b = (1, 0) and c = 2 (Re a, -Im a); the number t for a real t, with
b = 1 and c = a.  Its zeros are the finite generalized eigenvalues of the
pencil ([[L, b], [c^T, 0]], diag(I, 0)), which LAPACK's QZ (dggev) finds
backward stably whatever f's decay at infinity (a sum whose weights cancel,
such as sum 1/(x - c_k) - sum 1/(x - p_k), falls off like 1/x^d, d > 1): no
polynomial is expanded.  Polynomials are small here (at most `MAX_ROOTS` of
`engine.margins.pole_zero.search`): built by products and rooted by their balanced
companion matrices (dgeev), without np.poly's and np.roots's wrappers.

A sum of rational terms in factored form, sum_k g_k prod(x - z_k)/prod(x - p_k)
(an expression's sum, `engine.model.factored`), has its zeros from the same
kind of pencil, its terms realized as cascades (`factored_sum_zeros`), and
they are polished together by the Aberth-Ehrlich iteration on the sum itself
(`engine.numerics.aberth`, conjugate pairs kept exact: the polisher of the closed
loop's poles too).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import NDArray

FINITE = 1e-8  # |beta| / |alpha| of a finite eigenvalue: |x| < 1e8 max |t|
VANISHING = 1e-13  # weights all this small (relative to their sizes) make f vanish
LARGEST_LOG = math.log(np.finfo(float).max)  # the largest float's log: a larger scale has no float roots


class Fractions:
    """The pencil of sums over one set of poles t (closed under conjugation),
    equal poles merged: `zeros` takes the weights."""

    def __init__(self, t: NDArray[np.complex128]):
        real, upper = t.imag == 0, t.imag > 0
        self.closed = 2 * int(np.count_nonzero(upper)) + int(np.count_nonzero(real)) == t.size
        singles, pairs = t[real].real, t[upper]
        self.merge = len(set(t.tolist())) < t.size  # equal poles: their weights are summed
        if self.merge:
            singles, self.single_of = np.unique(singles, return_inverse=True)
            pairs, self.pair_of = np.unique(pairs, return_inverse=True)
        self.real, self.upper = real, upper
        self.scale = float(np.abs(t).max(initial=0.0)) or 1.0
        self.count, n = (singles.size, pairs.size), singles.size + 2 * pairs.size
        self.pencil, self.mass = np.zeros((n + 1, n + 1)), np.zeros((n + 1, n + 1))
        tp = pairs / self.scale
        self.pencil.flat[: n * (n + 2) : n + 2] = np.concatenate([singles / self.scale, np.repeat(tp.real, 2)])
        self.mass.flat[: n * (n + 2) : n + 2] = 1.0
        first = singles.size + 2 * np.arange(pairs.size)
        self.pencil[first, first + 1], self.pencil[first + 1, first] = -tp.imag, tp.imag
        self.pencil[: singles.size, n] = 1.0
        self.pencil[first, n] = 1.0
        self.first, self.n = first, n

    def weights(self, a: NDArray[np.complex128]) -> NDArray[np.complex128] | None:
        """The weights of sum a_k / (x - t_k) per distinct pole (equal poles' summed),
        scaled to a largest of 1; None when the sum vanishes identically (all within
        `VANISHING` of the largest given)."""
        singles, pairs = self.count
        if self.merge:
            weights = np.zeros(singles + pairs, dtype=complex)
            np.add.at(weights, self.single_of.ravel(), a[self.real])
            np.add.at(weights, singles + self.pair_of.ravel(), a[self.upper])
        else:
            weights = np.concatenate([a[self.real], a[self.upper]])
        size = float(np.abs(weights).max(initial=0.0))
        if not size > VANISHING * max(float(np.abs(a).max(initial=0.0)), 1e-300):
            return None
        return weights / size

    def zeros(self, a: NDArray[np.complex128], squared: bool = False) -> NDArray[np.complex128] | None:
        """The finite zeros of sum a_k / (x - t_k) (``squared``: of sum a_k /
        (x - t_k)^2, the system cascaded with its own resolvent: c^T (xI - L)^-2 b);
        None when the sum vanishes identically or its terms are not closed
        under conjugation."""
        weights = self.weights(a)
        return None if weights is None else self.zeros_of(weights, squared)

    def zeros_of(self, weights: NDArray[np.complex128], squared: bool = False) -> NDArray[np.complex128] | None:
        """`zeros` from the sum's `weights` (already made: a caller that asked whether
        the sum vanishes does not merge them again)."""
        if not self.closed:
            return None
        singles = self.count[0]
        pencil, n = self.pencil.copy(), self.n
        pencil[n, :singles] = weights[:singles].real
        pencil[n, self.first], pencil[n, self.first + 1] = 2 * weights[singles:].real, -2 * weights[singles:].imag
        mass = self.mass
        if squared:
            pencil, mass = _cascaded(pencil, n, True), _cascaded(mass, n, False)
        alpha_re, alpha_im, beta, *_, info = _lapack().dggev(pencil, mass, compute_vl=0, compute_vr=0)
        if info != 0:
            return None
        finite = np.abs(beta) > FINITE * np.hypot(alpha_re, alpha_im)
        return (alpha_re[finite] + 1j * alpha_im[finite]) / beta[finite] * self.scale


def conjugate_closed(roots: NDArray[np.complex128], tolerance: float = 1e-8) -> NDArray[np.complex128] | None:
    """``roots`` (a complex eigenvalue solver's, of a real problem) made exactly closed under
    conjugation: a root above the axis and the nearest conjugate of one below, within
    ``tolerance`` of its size, become an exact pair (their mean and its conjugate); a root
    left alone within ``tolerance`` of the axis becomes real; None when one is neither."""
    roots = np.asarray(roots, dtype=complex)
    upper, lower = roots[roots.imag > 0].tolist(), roots[roots.imag < 0].conj().tolist()
    reals, pairs = roots[roots.imag == 0].real.tolist(), []
    for u in sorted(upper, key=lambda x: -x.imag):  # farthest from the axis first: they pair surely
        k = min(range(len(lower)), key=lambda j: abs(lower[j] - u), default=None)
        if k is not None and abs(lower[k] - u) <= tolerance * abs(u):
            pairs.append((u + lower.pop(k)) / 2)
        elif u.imag <= tolerance * abs(u):
            reals.append(u.real)
        else:
            return None
    for x in lower:
        if x.imag > tolerance * abs(x):
            return None
        reals.append(x.real)
    half = np.array(pairs, dtype=complex)
    return np.concatenate([np.array(reals, dtype=complex), half, half.conj()])


def factored_sum_zeros(terms: list[tuple[float, NDArray, NDArray]]) -> NDArray[np.complex128] | None:
    """The finite zeros of sum_k g_k prod(x - z_k) / prod(x - p_k), every term proper and
    given as (g_k, z_k, p_k): the generalized eigenvalues of the pencil ([[A, B], [C, D]],
    diag(I, 0)) of the terms' realizations in parallel (LAPACK's QZ, zggev: backward stable).
    Each term is a cascade of first-order sections, (x - z)/(x - p) = 1 + (p - z)/(x - p)
    while zeros last, then 1/(x - p): no polynomial is formed, a repeated pole is a Jordan
    chain, and the variable is scaled by the largest root.  A pole that two terms share is
    a state of each, so it is a zero of this realization too (not of the sum: the caller
    removes it).  Complex: conjugate pairs come back close, not exact (`conjugate_closed`).
    None when a term is improper, a number leaves the floating-point range, or QZ fails."""
    if any(z.size > p.size for _, z, p in terms):
        return None
    scale = max((float(np.abs(np.concatenate([z, p])).max(initial=0.0)) for _, z, p in terms), default=0.0) or 1.0
    n = sum(p.size for _, _, p in terms)
    system, mass = np.zeros((n + 1, n + 1), dtype=complex), np.zeros((n + 1, n + 1), dtype=complex)
    mass[np.arange(n), np.arange(n)] = 1.0
    top = 0
    for gain, zeros, poles in terms:
        z, p = zeros / scale, poles / scale
        feed, through = np.zeros(p.size, dtype=complex), 1.0  # the next section's input: feed . x + through u
        for j in range(p.size):
            system[top + j, top + j] = p[j]
            system[top + j, top : top + j], system[top + j, n] = feed[:j], through
            if j < z.size:
                feed[j] += p[j] - z[j]
            else:
                feed, through = np.zeros(p.size, dtype=complex), 0.0
                feed[j] = 1.0
        scaled = gain * np.float64(scale) ** (z.size - p.size)  # a Python float's ** raises OverflowError
        system[n, top : top + p.size], system[n, n] = scaled * feed, system[n, n] + scaled * through
        top += p.size
    if not np.all(np.isfinite(system)):
        return None
    alpha, beta, *_, info = _lapack().zggev(system, mass, compute_vl=0, compute_vr=0)
    if info != 0:
        return None
    finite = np.abs(beta) > FINITE * np.abs(alpha)
    return alpha[finite] / beta[finite] * scale


def _cascaded(matrix: NDArray, n: int, system: bool) -> NDArray:
    """One side of the pencil of (L, b, c) followed by the resolvent of L again:
    states (x1, x2) with x x1 = L x1 + b u, x x2 = L x2 + x1, y = c^T x2
    (``system``: the [[A, B], [C, 0]] side; else the diag(I, 0) side)."""
    out = np.zeros((2 * n + 1, 2 * n + 1))
    state = matrix[:n, :n]
    out[:n, :n], out[n : 2 * n, n : 2 * n] = state, state
    out[:n, 2 * n], out[2 * n, n : 2 * n] = matrix[:n, n], matrix[n, :n]
    if system:
        out[n : 2 * n, :n] = np.eye(n)
    return out


def polynomial_sum(p: NDArray, q: NDArray) -> NDArray[np.float64]:
    """p + q, both in descending powers (the shorter one aligned at the constant term)."""
    out = np.zeros(max(p.size, q.size))
    out[out.size - p.size :] += p
    out[out.size - q.size :] += q
    return out


def poly(roots: NDArray) -> NDArray[np.float64]:
    """The monic polynomial (descending powers) with these roots, closed under
    conjugation (np.poly's products, in plain Python: these are small)."""
    c = [1.0 + 0j]
    for r in roots.tolist():
        c = [x - r * y for x, y in zip(c + [0j], [0j] + c)]
    return np.array(c).real


def roots(c: NDArray) -> NDArray[np.complex128]:
    """Roots of a polynomial (descending powers): its balanced companion
    matrix's eigenvalues, and 0 for each trailing zero coefficient.  The
    variable is scaled first by the roots' geometric mean, |c_n / c_0|^(1/n),
    so the companion's entries are moderate (dgeev returned the eigenvalues of
    its own rescaled matrix when they passed ~1e138).  The scaling is done on
    Python floats: these polynomials are small, and numpy's per-call cost was
    most of this function's time."""
    coefficients = c.tolist()
    nonzero = [k for k, value in enumerate(coefficients) if value != 0.0]
    if not nonzero or not all(map(math.isfinite, coefficients)):
        return np.zeros(0, dtype=complex)
    first, last = nonzero[0], nonzero[-1]
    at_origin = np.zeros(len(coefficients) - 1 - last, dtype=complex)
    n = last - first
    if n == 0:
        return at_origin
    lead = coefficients[first]
    log_lead = math.log(abs(lead))
    log_scale = (math.log(abs(coefficients[last])) - log_lead) / n
    if abs(log_scale) > LARGEST_LOG:  # roots beyond the floats (1e-300 x - 1e300): none to give
        return np.zeros(0, dtype=complex)
    row = []  # -c_k / c_0 * scale^-k, as logs: no overflow on the way
    for k, value in enumerate(coefficients[first + 1 : last + 1], start=1):
        if value == 0.0:
            row.append(0.0)
            continue
        level = math.log(abs(value)) - log_lead - log_scale * k
        if level > LARGEST_LOG:
            return np.zeros(0, dtype=complex)
        row.append(math.exp(level) if (value > 0) != (lead > 0) else -math.exp(level))
    companion = np.eye(n, k=-1)
    companion[0] = row
    real, imag, *_, info = _lapack().dgeev(companion, compute_vl=0, compute_vr=0)
    if info != 0:
        return np.zeros(0, dtype=complex)
    return np.concatenate([(real + 1j * imag) * math.exp(log_scale), at_origin])


@functools.cache
def _lapack():
    """scipy's LAPACK wrappers, imported on first use (start-up time; cached:
    an import statement run per call cost more than dgeev on these sizes)."""
    from scipy.linalg import lapack

    return lapack

"""Zeros of sums of simple fractions and of small polynomials, for the
margin search of a loop in pole-zero form (`engine.zpk_margins`).

A sum f(x) = sum a_k / (x - t_k) whose terms are closed under conjugation
((t, a) and (conj t, conj a) both in it) is c^T (x I - L)^-1 b for a real
block-diagonal L: a 2x2 block [[Re t, -Im t], [Im t, Re t]] per conjugate
pair with b = (1, 0) and c = 2 (Re a, -Im a); the number t for a real t, with
b = 1 and c = a.  Its zeros are the finite generalized eigenvalues of the
pencil ([[L, b], [c^T, 0]], diag(I, 0)), which LAPACK's QZ (dggev) finds
backward stably whatever f's decay at infinity (a sum whose weights cancel,
such as sum 1/(x - c_k) - sum 1/(x - p_k), falls off like 1/x^d, d > 1): no
polynomial is expanded.  Polynomials are small here (at most `MAX_ROOTS` of
`engine.zpk_margins`): built by products and rooted by their companion
matrices, without np.poly's and np.roots's wrappers.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

FINITE = 1e-8  # |beta| / |alpha| of a finite eigenvalue: |x| < 1e8 max |t|
CANCELLED = 1e-13  # a merged weight this small (relative to the largest) cancels


def fraction_zeros(t: NDArray, a: NDArray) -> NDArray[np.complex128] | None:
    """The finite zeros of sum a_k / (x - t_k) (module docstring); equal t are
    merged first.  None when f vanishes identically or the set is not closed
    under conjugation."""
    if t.size > 1 and np.count_nonzero(t[:, None] == t[None, :]) > t.size:
        t, a = merged(t, a)
    upper, real = t.imag > 0, t.imag == 0
    pairs, singles = int(np.count_nonzero(upper)), int(np.count_nonzero(real))
    if t.size == 0 or 2 * pairs + singles != t.size:
        return None
    scale, size = float(np.abs(t).max()) or 1.0, float(np.abs(a).max())
    if size == 0:
        return None
    tr, ar, tp, ap = t[real].real / scale, a[real].real / size, t[upper] / scale, a[upper] / size
    n = t.size
    pencil, mass = np.zeros((n + 1, n + 1)), np.zeros((n + 1, n + 1))
    pencil.flat[:n * (n + 2):n + 2] = np.concatenate([tr, np.repeat(tp.real, 2)])
    mass.flat[:n * (n + 2):n + 2] = 1.0
    first = singles + 2 * np.arange(pairs)
    pencil[first, first + 1], pencil[first + 1, first] = -tp.imag, tp.imag
    pencil[:singles, n] = 1.0
    pencil[first, n] = 1.0
    pencil[n, :singles] = ar
    pencil[n, first], pencil[n, first + 1] = 2 * ap.real, -2 * ap.imag
    alpha_re, alpha_im, beta, *_, info = lapack.dggev(pencil, mass, compute_vl=0, compute_vr=0)
    if info != 0:
        return None
    finite = np.abs(beta) > FINITE * np.hypot(alpha_re, alpha_im)
    return (alpha_re[finite] + 1j * alpha_im[finite]) / beta[finite] * scale


def merged(t: NDArray, a: NDArray) -> tuple[NDArray, NDArray]:
    """Equal t merged (their weights summed), terms that cancel dropped."""
    order = np.argsort(t)
    t, a = t[order], a[order]
    starts = np.flatnonzero(np.concatenate([[True], t[1:] != t[:-1]]))
    t, a = t[starts], np.add.reduceat(a, starts)
    keep = np.abs(a) > CANCELLED * max(float(np.abs(a).max(initial=0.0)), 1e-300)
    return t[keep], a[keep]


def poly(roots: NDArray) -> NDArray[np.float64]:
    """The monic polynomial (descending powers) with these roots, closed under
    conjugation (np.poly's products, in plain Python: these are small)."""
    c = [1.0 + 0j]
    for r in roots.tolist():
        c = [x - r * y for x, y in zip(c + [0j], [0j] + c)]
    return np.array(c).real


def roots(c: NDArray) -> NDArray[np.complex128]:
    """Roots of a polynomial (descending powers): its companion matrix's
    eigenvalues (balanced by LAPACK), and 0 for each trailing zero coefficient."""
    nonzero = np.flatnonzero(c)
    if nonzero.size == 0 or not np.isfinite(c).all():
        return np.zeros(0, dtype=complex)
    first, last = int(nonzero[0]), int(nonzero[-1])
    at_origin = np.zeros(c.size - 1 - last, dtype=complex)
    if last == first:
        return at_origin
    companion = np.eye(last - first, k=-1)
    companion[0] = -c[first + 1:last + 1] / c[first]
    return np.concatenate([np.linalg.eigvals(companion), at_origin])

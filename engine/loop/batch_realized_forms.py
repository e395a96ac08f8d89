"""The minimal pole-zero forms of many samples of a loop that is not one cascade (parallel
paths, blocks that share a mode), from their stacked realizations
(`engine.loop.batch_realization`), with no per-sample eigenvalue call.

For each sample's loop broken at signal k (GH = -(C_k (sI - A)^-1 B_u + D_ku), as
`engine.loop.pole_zero.realized_roots` reads the realization): the poles are the
eigenvalues of A; the zeros and the gain come from the zero dynamics, which numpy batches
where the generalized eigenvalues (QZ) are not: with r the relative degree (the first
Markov parameter c A^(r-1) b that is not zero, `STRUCTURAL`), the feedback
u = -(c A^r x) / (c A^(r-1) b) makes A_r = A - b c A^r / (c A^(r-1) b), which leaves the
subspace c = cA = ... = cA^(r-1) = 0 invariant; its eigenvalues there are the finite zeros
(the n - r others are at 0), and the gain is c A^(r-1) b (d, with A - b c / d, when r = 0).
So no infinite generalized eigenvalue is read as a finite zero (QZ gives the launch
vehicle a zero at 3e12 rad/s and a gain of 5e-9 for its relative degree 5).

A mode the loop holds several times (the same bending mode realized by a gyro's, a rate
gyro's and an accelerometer's block: only one combination of the copies reaches the loop)
is a pole cancelled by a zero; such pairs, equal to `CANCEL` of the pole, are left out of
the form and kept as ``hidden`` poles (they are closed-loop poles all the same: the
closed-loop poles of the closed realizations, `closed`, include them).  A root within
`AT_ZERO` of the matrix's size is an integrator (eigenvalues place it at 1e-16 off the axis):
it is put at 0.

A sample whose relative degree differs from the first sample's, whose number of cancelled
pairs differs from most samples', or whose numbers are not finite, is ``odd`` (the per-loop
path takes it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.loop.batch_forms import BatchForms
from engine.loop.batch_realization import SharedStateSpace, closed_poles
from engine.loop.realization import StateSpace

STRUCTURAL = 1e-10  # a Markov parameter c A^j b below this of |c A^(j-1)| |A| |b| is a structural zero
CANCEL = 1e-12  # relative distance of a zero to a pole below which the pair cancels (2e-15 measured)
AT_ZERO = 1e-13  # a root below this times |A| is at 0
POINTS = 2048  # points `RealizedForms.response` solves at once (their matrices: 26 MB at 28 states)


@dataclass(frozen=True)
class RealizedForms:
    """Every sample's minimal form, its cancelled (hidden) poles (S, h), and its loop's
    realization GH(s) = gh_c (sI - A)^-1 gh_b + gh_d, for evaluating GH exactly; ``closed``: the
    closed-loop poles from the closed realizations (`engine.loop.batch_realization.closed_poles`,
    as the per-loop path reads them; None for a singular algebraic loop)."""

    forms: BatchForms
    hidden: NDArray[np.complex128]
    realization: StateSpace  # the stacked broken loops they come from
    A: NDArray[np.float64]
    b: NDArray[np.float64]
    c: NDArray[np.float64]
    d: NDArray[np.float64]
    closed: NDArray[np.complex128] | None = None

    def response(
        self, samples: NDArray[np.intp], w: NDArray[np.float64], slope: bool = False
    ) -> tuple[NDArray[np.complex128], NDArray[np.complex128] | None]:
        """GH(j w) of sample ``samples[i]`` at ``w[i]`` from its realization, and (``slope``)
        dGH/domega there (None without), `POINTS` points at a time (the memory stays bounded)."""
        gh = np.empty(w.size, dtype=complex)
        dgh = np.empty(w.size, dtype=complex) if slope else None
        n = self.A.shape[1]
        for first in range(0, w.size, POINTS):
            part, rows = slice(first, first + POINTS), samples[first : first + POINTS]
            pencil = 1j * w[part, None, None] * np.eye(n) - self.A[rows]
            x = np.linalg.solve(pencil, self.b[rows][:, :, None])
            gh[part] = np.einsum("in,in->i", self.c[rows], x[:, :, 0]) + self.d[rows]
            if dgh is not None:
                dgh[part] = -1j * np.einsum("in,in->i", self.c[rows], np.linalg.solve(pencil, x)[:, :, 0])
        return gh, dgh


def realized_forms(ss: StateSpace, k: int) -> RealizedForms | None:
    """The minimal forms of the loops broken at signal ``k`` of the stacked broken networks
    ``ss`` (`engine.loop.batch_realization.batch_loop_realization`; the poles of states it
    shared, `SharedStateSpace.hidden`, are hidden poles too); None when the first sample has no
    finite form (no states, no nonzero Markov parameter)."""
    A, b, c, d = ss.A, ss.B[:, :, -1], -ss.C[:, k, :], -ss.D[:, k, -1]
    if A.shape[1] == 0:
        return None
    finite = np.isfinite(A).all(axis=(1, 2)) & np.isfinite(b).all(axis=1) & np.isfinite(c).all(axis=1)
    A, b, c, d = (np.where(_rows(finite, m), m, 0.0) for m in (A, b, c, d))
    found = _zero_dynamics(A, b, c, d)
    if found is None:
        return None
    gain, zeros, odd = found
    poles = np.linalg.eigvals(A)
    size = np.linalg.norm(A, axis=(1, 2))[:, None]
    poles, zeros = (np.where(np.abs(r) <= AT_ZERO * size, 0j, r) for r in (poles, zeros))
    zeros, poles, hidden, apart = _cancelled(zeros, poles)
    if isinstance(ss, SharedStateSpace):
        hidden = np.concatenate([hidden, ss.hidden], axis=1)
    odd |= apart | ~finite | ~np.isfinite(gain) | (gain == 0)
    closed = closed_poles(ss, k)
    forms = BatchForms(np.where(odd, 1.0, gain), zeros, poles, odd)
    return RealizedForms(forms, hidden, ss, A, b, c, d, closed)


def _rows(mask: NDArray[np.bool_], m: NDArray) -> NDArray[np.bool_]:
    return mask.reshape(-1, *([1] * (m.ndim - 1)))


def _zero_dynamics(
    A: NDArray, b: NDArray, c: NDArray, d: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.complex128], NDArray[np.bool_]] | None:
    """Every sample's gain, finite zeros (module docstring) and whether its relative degree
    differs from the first sample's (odd); None when the first sample has none."""
    count, n = A.shape[0], A.shape[1]
    scale = np.maximum(np.linalg.norm(A, axis=(1, 2)), 1e-300)
    reach = np.linalg.norm(b, axis=1) * np.linalg.norm(c, axis=1) / scale  # the rounding's size: |b| |c A^(j-1)| |A|
    present = [np.abs(d) > STRUCTURAL * reach]  # present[j]: the j-th Markov parameter (d first)
    markov, rows = [d], [c]
    while not present[-1][0]:
        if len(rows) > n:
            return None
        markov.append(np.einsum("sn,sn->s", rows[-1], b))
        present.append(np.abs(markov[-1]) > STRUCTURAL * reach * scale)
        reach = np.linalg.norm(b, axis=1) * np.linalg.norm(rows[-1], axis=1)
        rows.append(np.einsum("sn,snm->sm", rows[-1], A))
    r = len(present) - 1
    odd = ~present[-1] | np.logical_or.reduce(present[:-1], axis=0) if r else ~present[-1]
    gain = np.where(odd, 1.0, markov[-1])
    top = rows[r]  # c A^r (c when r = 0)
    closed = A - b[:, :, None] * top[:, None, :] / gain[:, None, None]
    if r == 0:
        return gain, np.linalg.eigvals(closed), odd
    observed = np.stack(rows[:r], axis=1)  # (S, r, n): c, cA, ..., cA^(r-1)
    unit = observed / np.maximum(np.linalg.norm(observed, axis=2, keepdims=True), 1e-300)
    q = np.linalg.qr(np.swapaxes(unit, 1, 2), mode="complete")[0]
    basis = q[:, :, r:]  # (S, n, n - r): the subspace c A^j x = 0, j < r, that A_r leaves invariant
    zeros = np.linalg.eigvals(np.swapaxes(basis, 1, 2) @ closed @ basis) if n > r else np.zeros((count, 0), complex)
    return gain, zeros, odd


def _cancelled(
    zeros: NDArray, poles: NDArray
) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.complex128], NDArray[np.bool_]]:
    """The zeros and poles with the pairs within `CANCEL` left out (each zero takes its nearest
    pole still free), the poles left out, and the samples whose count of pairs is not the most
    samples' (odd: their arrays are that count's shape, their values meaningless; two time
    constants drawn equal cancel one pair more)."""
    count = zeros.shape[0]
    free = np.ones(poles.shape, dtype=bool)
    kept = np.ones(zeros.shape, dtype=bool)
    rows = np.arange(count)
    for i in range(zeros.shape[1]):
        with np.errstate(all="ignore"):  # (a zero and a pole both at 0: a gap of 0)
            gap = np.abs(poles - zeros[:, i : i + 1]) / np.maximum(np.abs(poles), 1e-300)
        gap = np.where(free & np.isfinite(gap), gap, np.inf)
        nearest = np.argmin(gap, axis=1)
        pair = gap[rows, nearest] <= CANCEL
        free[rows[pair], nearest[pair]] = False
        kept[pair, i] = False
    pairs = (~kept).sum(axis=1)
    usual = int(np.bincount(pairs).argmax())
    odd = pairs != usual
    if odd.any():  # a placeholder layout: the usual count of pairs
        kept[odd], free[odd] = True, True
        kept[odd, :usual], free[odd, :usual] = False, False
    m, p = zeros.shape[1] - usual, poles.shape[1] - usual
    return zeros[kept].reshape(count, m), poles[free].reshape(count, p), poles[~free].reshape(count, -1), odd

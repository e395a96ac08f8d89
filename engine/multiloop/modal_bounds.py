"""A rational matrix N(s) = D + sum_i c_i b_i' / (s - p_i) in modal form, with the bounds of its
change over a frequency interval that the certificates of a loop with delays read
(`engine.multiloop.delayed`, `engine.multiloop.delay_stability`).

Blocks.  N's rows and columns are split after the first ``split`` (the loops, then the delays);
block (I, J) of the residue c_i b_i' has the norm |c_i,I| |b_i,J| (rank one), the loop rows
scaled by D = e^X and the loop columns by D^-1 where a D-scale applies.

Change over an interval.  For omega in [lo, hi] and its middle w0,

    |N_IJ(j omega) - N_IJ(j w0)| <= |omega - w0| sum_i |c_i,I| |b_i,J| / (d_i |j w0 - p_i|),

d_i the distance from p_i to the segment j [lo, hi] (1/(j omega - p) - 1/(j w0 - p) =
j (w0 - omega) / ((j omega - p)(j w0 - p))).  Beyond a frequency W, on the axis and on
|s| >= W in the right half-plane, |N_IJ(s) - N_IJ(inf)| <= sum_i |c_i,I| |b_i,J| / d_i with
d_i the distance from p_i to those points (`tail`).  The modal form is built only when the
eigenvectors are well conditioned (`MODAL_CONDITION`): its rounding is then far below the
certificates' margins.  The plant path's searches evaluate their sensitivity by it too
(`engine.multiloop.disk.System.fast`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

MODAL_CONDITION = 1e8  # cond(V) of A's eigenvectors up to which the modal form (and its bounds) is used


@dataclass(frozen=True)
class Modal:
    """N(s) = d + left diag(1/(s - poles)) right, rows and columns split after ``split``."""

    poles: NDArray[np.complex128]
    left: NDArray[np.complex128]
    right: NDArray[np.complex128]
    d: NDArray[np.float64]
    split: int

    def at(self, omega: NDArray) -> NDArray[np.complex128]:
        """N(j omega) at each frequency (inf: d): points x rows x columns."""
        omega = np.asarray(omega, dtype=float)
        with np.errstate(all="ignore"):
            inverse = np.where(np.isfinite(omega)[:, None], 1.0 / (1j * omega[:, None] - self.poles[None, :]), 0.0)
        return self.d[None, :, :] + (self.left[None, :, :] * inverse[:, None, :]) @ self.right[None, :, :]

    def residues(self, x: NDArray) -> dict[tuple[int, int], NDArray[np.float64]]:
        """|c_i,I| |b_i,J| for each block (I, J) (0: loops, 1: delays), under the log scales ``x``
        (points x loops): points x poles each."""
        s = self.split
        rows = np.abs(self.left) ** 2
        cols = np.abs(self.right) ** 2
        c = (
            np.sqrt(np.exp(2.0 * x) @ rows[:s]),
            np.broadcast_to(np.sqrt(rows[s:].sum(axis=0)), (x.shape[0], rows.shape[1])),
        )
        b = (
            np.sqrt(np.exp(-2.0 * x) @ cols[:, :s].T),
            np.broadcast_to(np.sqrt(cols[:, s:].sum(axis=1)), (x.shape[0], cols.shape[0])),
        )
        return {(i, j): c[i] * b[j] for i in (0, 1) for j in (0, 1)}

    def change(self, lo: NDArray, hi: NDArray, x: NDArray) -> dict[tuple[int, int], NDArray[np.float64]]:
        """Bounds of |N_IJ(j omega) - N_IJ(j w0)| over each [lo, hi], w0 its middle (module docstring)."""
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        p = self.poles[None, :]
        nearest = np.clip(p.imag, lo[:, None], hi[:, None])
        weight = half[:, None] / (np.abs(1j * nearest - p) * np.abs(1j * mid[:, None] - p))
        return {key: (r * weight).sum(axis=1) for key, r in self.residues(x).items()}

    def distance(self, omega: NDArray) -> NDArray[np.float64]:
        """The distance from j omega to the nearest pole (inf without poles)."""
        if not self.poles.size:
            return np.full(np.shape(omega), np.inf)
        return np.abs(1j * np.asarray(omega)[:, None] - self.poles[None, :]).min(axis=1)

    def disc(self, mid: NDArray, radius: NDArray, x: NDArray) -> dict[tuple[int, int], NDArray[np.float64]]:
        """Bounds of |N_IJ(s) - N_IJ(j mid)| over each disc |s - j mid| <= radius (below the distance to
        every pole): |1/(s - p) - 1/(j mid - p)| <= radius / ((d - radius) d), d = |j mid - p|."""
        d = np.abs(1j * mid[:, None] - self.poles[None, :])
        weight = radius[:, None] / ((d - radius[:, None]) * d)
        return {key: (r * weight).sum(axis=1) for key, r in self.residues(x).items()}

    def tail(self, top: float, x: NDArray, half_plane: bool) -> dict[tuple[int, int], NDArray[np.float64]]:
        """Bounds of |N_IJ(s) - N_IJ(inf)| for s = j omega, omega >= ``top`` (and |s| >= top, Re s >= 0
        when ``half_plane``), under the log scales ``x`` (module docstring)."""
        p = self.poles
        if top == math.inf:
            return {key: np.zeros(x.shape[0]) for key in ((0, 0), (0, 1), (1, 0), (1, 1))}
        on_axis = np.abs(p - 1j * np.maximum(p.imag, top))
        distance = np.minimum(on_axis, np.maximum(top - np.abs(p), 0.0)) if half_plane else on_axis
        with np.errstate(divide="ignore"):
            weight = 1.0 / distance
        return {key: (r * weight[None, :]).sum(axis=1) for key, r in self.residues(x).items()}


def modal(
    a: NDArray, b: NDArray, c: NDArray, d: NDArray, split: int, condition: float = MODAL_CONDITION
) -> Modal | None:
    """The modal form of (a, b, c, d); None when A's eigenvectors' condition exceeds ``condition``."""
    if a.shape[0] == 0:
        empty = np.zeros((c.shape[0], 0), dtype=complex)
        return Modal(np.zeros(0, dtype=complex), empty, np.zeros((0, b.shape[1]), dtype=complex), d, split)
    values, vectors = np.linalg.eig(a)
    if not np.linalg.cond(vectors) <= condition:
        return None
    return Modal(values, c @ vectors, np.linalg.solve(vectors, b.astype(complex)), d, split)

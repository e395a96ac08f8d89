"""Where the singular values of G(j omega) = C (j omega I - A)^-1 B + D cross a level gamma
(Boyd, Balakrishnan and Kabamba 1989; Bruinsma and Steinbuch 1990): with A free of
imaginary-axis eigenvalues and gamma no singular value of D, gamma is a singular value of
G(j omega) exactly when j omega is an eigenvalue of the Hamiltonian matrix

    H = [[A - B R^-1 D' C,      -gamma B R^-1 B'     ],
         [gamma C' S^-1 C,      -A' + C' D R^-1 B'  ]],   R = D'D - gamma^2 I, S = DD' - gamma^2 I.

Between two consecutive crossings no singular value equals gamma, so sigma_max - gamma keeps
one sign there, read at one point.  Eigenvalues are taken as on the axis within
`AXIS_TOLERANCE` of H's size: a crossing's eigenvalue is moved off the axis by rounding
(by about the square root of the precision where two crossings merge), and an extra
candidate only splits an interval once more, while a missed one would be a wrong
certificate."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

AXIS_TOLERANCE = 1e-6  # |Re lambda| <= this * (|H| + |lambda|): taken as a crossing
RESPONSE_POINTS = 1 << 16  # points of one batch of G(j omega) (each an n x m solve)


def crossings(a: NDArray, b: NDArray, c: NDArray, d: NDArray, gamma: float) -> NDArray[np.float64] | None:
    """The frequencies omega >= 0 (sorted) where a singular value of G(j omega) may equal
    ``gamma`` (module docstring); None when gamma is a singular value of D (no test)."""
    m_in, m_out = b.shape[1], c.shape[0]
    if a.shape[0] == 0:  # a static gain: its singular values are those of D at every frequency
        return np.zeros(0) if np.all(np.abs(np.linalg.svd(d, compute_uv=False) - gamma) > 1e-12 * gamma) else None
    r = d.T @ d - gamma**2 * np.eye(m_in)
    s = d @ d.T - gamma**2 * np.eye(m_out)
    if min(abs(np.linalg.eigvalsh(r)).min(), abs(np.linalg.eigvalsh(s)).min()) <= 1e-12 * gamma**2:
        return None
    rb = np.linalg.solve(r, b.T)  # R^-1 B'
    rdc = np.linalg.solve(r, d.T @ c)  # R^-1 D' C
    h = np.block([[a - b @ rdc, -gamma * b @ rb], [gamma * c.T @ np.linalg.solve(s, c), -a.T + c.T @ d @ rb]])
    values = np.linalg.eigvals(h)
    size = np.abs(h).sum(axis=0).max()
    near = np.abs(values.real) <= AXIS_TOLERANCE * (size + np.abs(values))
    return np.unique(np.abs(values[near].imag))


def response(a: NDArray, b: NDArray, c: NDArray, d: NDArray, omega: NDArray) -> NDArray[np.complex128]:
    """G(j omega) at each frequency (points x outputs x inputs); omega inf gives D."""
    omega = np.asarray(omega, dtype=float)
    out = np.broadcast_to(d.astype(complex), (omega.size, *d.shape)).copy()
    finite = np.flatnonzero(np.isfinite(omega))
    n = a.shape[0]
    if n == 0 or not finite.size:
        return out
    step = max(1, RESPONSE_POINTS // max(n * n, 1))
    for start in range(0, finite.size, step):
        at = finite[start : start + step]
        pencil = 1j * omega[at, None, None] * np.eye(n) - a[None, :, :]
        out[at] += c[None, :, :] @ np.linalg.solve(pencil, np.broadcast_to(b.astype(complex), (at.size, *b.shape)))
    return out

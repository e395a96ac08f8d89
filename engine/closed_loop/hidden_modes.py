"""Closed-loop poles the loop cannot move: the modes of a realization that are uncontrollable or
unobservable from the loop (a block's pole cancelled by its own zero, a sensor block's copy of a
mode another block also carries).  They are eigenvalues of the closed loop, fixed whatever the
compensator's gain, and no root of the characteristic equation of the blocks' factored forms.

The Popov-Belevitch-Hautus test on the balanced realization (scipy.linalg.matrix_balance): a pole
lambda of A (the closed loop, loop input b, loop output c) is uncontrollable from the loop when
[lambda I - A, b] loses rank, unobservable when [lambda I - A; c] does; a singular value counts as
zero below `RELATIVE_TOLERANCE` times the matrix's largest.  Of m equal poles, as many as the rank
lost are hidden (the launch vehicle's bending mode, carried by three sensor blocks: two copies).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

RELATIVE_TOLERANCE = 1e-8  # a singular value below this times the largest is zero
SAME_POLE = 1e-6  # poles closer than this (relative) are copies of one mode


def hidden_modes(A: NDArray, b: NDArray, c: NDArray, poles: Sequence[complex]) -> tuple[str, ...]:
    """For each of ``poles`` (eigenvalues of A): "uncontrollable", "unobservable" or "uncontrollable and
    unobservable" from the loop (input b, output c), or "" for a mode the loop moves."""
    from scipy.linalg import matrix_balance

    balanced, scaling = matrix_balance(np.asarray(A, dtype=float), permute=False)
    b = np.asarray(b, dtype=float).reshape(-1, 1) / scaling.diagonal()[:, None]
    c = np.asarray(c, dtype=float).reshape(1, -1) * scaling.diagonal()[None, :]
    labels = [""] * len(poles)
    done: set[int] = set()
    for i, p in enumerate(poles):
        if i in done:
            continue
        copies = [j for j, q in enumerate(poles) if abs(q - p) <= SAME_POLE * max(abs(p), 1.0)]
        done.update(copies)
        shifted = p * np.eye(balanced.shape[0]) - balanced
        lost_c = _rank_lost(np.hstack([shifted, b.astype(complex)]))
        lost_o = _rank_lost(np.vstack([shifted, c.astype(complex)]))
        kind = " and ".join(k for k, lost in (("uncontrollable", lost_c), ("unobservable", lost_o)) if lost)
        for j in copies[: min(len(copies), max(lost_c, lost_o))]:
            labels[j] = kind
    return tuple(labels)


def _rank_lost(M: NDArray) -> int:
    """How many of min(M.shape) singular values are zero (below `RELATIVE_TOLERANCE` of the largest)."""
    s = np.linalg.svd(M, compute_uv=False)
    return int(np.sum(s <= RELATIVE_TOLERANCE * max(s[0], np.finfo(float).tiny))) if s.size else 0

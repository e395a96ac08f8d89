"""Closed-loop poles the loop cannot move: the modes of a realization that are uncontrollable or
unobservable from the loop (a block's pole cancelled by its own zero, a sensor block's copy of a
mode another block also carries).  They are eigenvalues of the closed loop, fixed whatever the
compensator's gain, and no root of the characteristic equation of the blocks' factored forms.

The Popov-Belevitch-Hautus test on the balanced realization (scipy.linalg.matrix_balance): a pole
lambda of A (the closed loop, loop input b, loop output c) is uncontrollable from the loop when
[lambda I - A, b] loses rank, unobservable when [lambda I - A; c] does; a singular value counts as
zero below `RELATIVE_TOLERANCE` times the matrix's largest.  Of m equal poles, as many as the rank
lost are hidden (the launch vehicle's bending mode, carried by three sensor blocks: two copies).

Feedback moves no uncontrollable or unobservable mode, so a fixed mode is an eigenvalue of the open
loop too: a pole farther than `OPEN_LOOP` (relative) from every open-loop eigenvalue is one
the loop moved, and is not tested.  The rank test alone is not blind to the realization's order: on
a cascade of 50 sections the singular values of [lambda I - A, b] fall below 1e-8 of the largest
for modes the gain moved by 90 % (every pole of a 57-pole loop was named a fixed mode), and a mode a
small gain moves by less than 1e-8 is as still as a fixed one.  So a loop whose form is read off its
blocks' own factors (a cascade: `engine.loop.pole_zero`) says how many copies of a mode the loop
transfer keeps (its poles there less its zeros there): those are moved by the gain, only the others
can be hidden.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

RELATIVE_TOLERANCE = 1e-8  # a singular value below this times the largest is zero
SAME_POLE = 1e-6  # poles closer than this (relative) are copies of one mode
OPEN_LOOP = 1e-8  # a fixed mode is an open-loop eigenvalue to this (relative): it does not move (seen: 8e-16)


def hidden_modes(
    open_loop: NDArray, b: NDArray, c: NDArray, poles: Sequence[complex], factored: Factored | None = None
) -> tuple[str, ...]:
    """For each of ``poles`` (eigenvalues of the closed loop A = ``open_loop`` + b c): "uncontrollable",
    "unobservable" or "uncontrollable and unobservable" from the loop (input b, output c), or "" for a
    mode the loop moves (one farther than `OPEN_LOOP` from every eigenvalue of ``open_loop`` is; with the
    loop's ``factored`` form, exact to rounding, as many copies of a mode as it keeps uncancelled are)."""
    from scipy.linalg import matrix_balance

    A_open = np.asarray(open_loop, dtype=float)
    balanced, scaling = matrix_balance(A_open + np.outer(b, c), permute=False)
    b = np.asarray(b, dtype=float).reshape(-1, 1) / scaling.diagonal()[:, None]
    c = np.asarray(c, dtype=float).reshape(1, -1) * scaling.diagonal()[None, :]
    labels = [""] * len(poles)
    eigenvalues = np.linalg.eigvals(matrix_balance(A_open, permute=False)[0])  # not A - b c: b c can be 1e38
    done: set[int] = set()
    for i, p in enumerate(poles):
        if i in done or not _an_open_loop_pole(p, eigenvalues):
            continue
        copies = [j for j, q in enumerate(poles) if abs(q - p) <= SAME_POLE * max(abs(p), 1.0)]
        done.update(copies)
        shifted = p * np.eye(balanced.shape[0]) - balanced
        lost_c = _rank_lost(np.hstack([shifted, b.astype(complex)]))
        lost_o = _rank_lost(np.vstack([shifted, c.astype(complex)]))
        kind = " and ".join(k for k, lost in (("uncontrollable", lost_c), ("unobservable", lost_o)) if lost)
        hidden = min(len(copies), max(lost_c, lost_o))
        if factored is not None:
            hidden = min(hidden, factored.hideable(p, len(copies)))
        for j in copies[:hidden]:
            labels[j] = kind
    return tuple(labels)


class Factored(NamedTuple):
    """The loop's zeros and poles read off its blocks' own factors (exact to rounding)."""

    zeros: NDArray[np.complex128]
    poles: NDArray[np.complex128]

    def hideable(self, mode: complex, copies: int) -> int:
        """How many of ``copies`` closed-loop poles at ``mode`` (within `SAME_POLE`) can be hidden: those
        beyond the loop's poles there that no zero cancels; none where the loop has more zeros than poles
        there (a high gain's closed-loop pole on a zero: no block has a mode there to hide)."""
        near = SAME_POLE * max(abs(mode), 1.0)
        poles = int(np.sum(np.abs(self.poles - mode) <= near))
        zeros = int(np.sum(np.abs(self.zeros - mode) <= near))
        return 0 if zeros > poles else copies - (poles - zeros)


def _an_open_loop_pole(pole: complex, open_loop: NDArray) -> bool:
    """Is ``pole`` within `OPEN_LOOP` of an open-loop eigenvalue (relative to it, or to the largest
    eigenvalue's eps at the origin)?"""
    if not open_loop.size:
        return False
    floor = np.finfo(float).eps * float(np.max(np.abs(open_loop)))
    return float(np.min(np.abs(open_loop - pole))) <= OPEN_LOOP * abs(pole) + floor


def _rank_lost(M: NDArray) -> int:
    """How many of min(M.shape) singular values are zero (below `RELATIVE_TOLERANCE` of the largest)."""
    s = np.linalg.svd(M, compute_uv=False)
    return int(np.sum(s <= RELATIVE_TOLERANCE * max(s[0], np.finfo(float).tiny))) if s.size else 0

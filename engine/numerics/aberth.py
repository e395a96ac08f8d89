"""The one Aberth-Ehrlich polisher: the roots of a function known through its logarithmic
derivative f'/f, refined together so that two estimates never settle on one simple root.

Each root x_i steps by 1 / (f'/f(x_i) - sum over the others 1/(x_i - x_j)) (Newton's
correction deflated by the other roots; 0 where f'/f is infinite: on a root exactly).  It
serves the closed-loop poles (`engine.closed_loop.characteristic`, f the characteristic
equation) and the zeros of sums of fractions (`engine.numerics.fraction_sums`, f a sum's
numerator), through the iteration driver (`engine.numerics.iteration`): a root that stops
leaves the active set and no longer moves (it still repels the others).

The stopping rule, one for both (the stricter of the two rules they had): a root is
CONVERGED when its correction is within `DONE` (4 ulp) of it, and STALLED when its
correction, below `FLOOR` relative, no longer halves (the noise of f'/f's evaluation
reached: waiting for 4 ulp there ran every round); FAILED where a correction is not
finite (the root stays where it was); ROUNDS when `ROUNDS` steps did not settle it.

A real function's roots can be kept in exact conjugate pairs (``conjugate``): only the
real ones and those above the axis are iterated, the lower ones are their mirror images
and real roots step along the axis.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from engine.numerics.iteration import Status, Work, iterate

Roots = NDArray[np.complex128]
LogSlope = Callable[[Roots], Roots]  # x -> f'(x)/f(x), infinite on a root

ROUNDS = 50  # cubic convergence from a few digits takes about five
DONE = 4 * np.finfo(float).eps  # relative correction at which a root is converged
FLOOR = 1e-11  # ... below which a correction that does not halve is the evaluation's noise


class Polished(NamedTuple):
    """The roots (the start's order; with ``conjugate``: reals, upper, lower), each one's
    status (`engine.numerics.iteration.Status`) and its last correction."""

    roots: Roots
    status: NDArray[np.int8]
    steps: Roots

    @property
    def settled(self) -> NDArray[np.bool_]:
        """Converged or stalled at the noise (a frozen root counts as converged)."""
        return (self.status == Status.CONVERGED) | (self.status == Status.STALLED)


def aberth(
    log_slope: LogSlope,
    start: Roots,
    frozen: NDArray[np.bool_] | None = None,
    conjugate: bool = False,
    rounds: int = ROUNDS,
) -> Polished:
    """The roots near ``start`` polished (module docstring); ``frozen`` roots do not move (a
    pair by its upper root's mark).  With ``conjugate``, roots not closed under conjugation
    come back unchanged, FAILED; roots that leave the floating-point range: the start, FAILED."""
    start = np.asarray(start, dtype=complex)
    frozen = np.zeros(start.size, dtype=bool) if frozen is None else np.asarray(frozen, dtype=bool)
    if conjugate and not _closed(start):
        return Polished(start, np.full(start.size, Status.FAILED, dtype=np.int8), np.zeros(start.size, dtype=complex))
    order = np.concatenate([np.flatnonzero(start.imag == 0), np.flatnonzero(start.imag > 0)]) if conjugate else None
    half = start[order] if order is not None else start.copy()
    mirrored = half.imag > 0 if conjugate else np.zeros(half.size, dtype=bool)
    on_axis = half.imag == 0 if conjugate else np.zeros(half.size, dtype=bool)
    status = np.where(frozen[order] if order is not None else frozen, Status.CONVERGED, Status.RUNNING).astype(np.int8)
    steps = np.zeros(half.size, dtype=complex)

    def advance(work: Work) -> Work:
        index = work["index"]
        x = half[index]
        every = np.concatenate([half, half[mirrored].conj()])
        gaps = x[:, None] - every[None, :]
        gaps[np.arange(index.size), index] = np.inf  # a root does not repel itself
        slope = log_slope(x)
        step = np.where(np.isinf(slope), 0.0, 1.0 / (slope - np.sum(1.0 / gaps, axis=1)))
        step = np.where(on_axis[index], step.real, step)
        finite = np.isfinite(step)
        half[index] = np.where(finite, x - step, x)
        steps[index] = np.where(finite, step, 0.0)
        relative = np.abs(step) / np.maximum(np.abs(half[index]), 1e-300)
        return work | {"last": work["relative"], "relative": relative, "failed": ~finite}

    def finish(work: Work, which: NDArray[np.bool_], why: NDArray[np.int8]) -> None:
        status[work["index"][which]] = why

    moving = np.flatnonzero(status == Status.RUNNING)
    work = {"index": moving, "relative": np.full(moving.size, np.inf), "last": np.full(moving.size, np.inf)}
    work["failed"] = np.zeros(moving.size, dtype=bool)
    with np.errstate(all="ignore"):
        iterate(work, _stopped, advance, finish, rounds)
    if not np.all(np.isfinite(half)):
        return Polished(start, np.full(start.size, Status.FAILED, dtype=np.int8), np.zeros(start.size, dtype=complex))
    if not conjugate:
        return Polished(half, status, steps)
    lower = mirrored
    return Polished(
        np.concatenate([half, half[lower].conj()]),
        np.concatenate([status, status[lower]]),
        np.concatenate([steps, steps[lower].conj()]),
    )


def _stopped(work: Work) -> NDArray[np.int8]:
    """The rule of the module docstring, from each root's last two relative corrections."""
    relative, last = work["relative"], work["last"]
    stalled = (relative <= FLOOR) & (relative >= 0.5 * last)
    status = np.where(relative <= DONE, Status.CONVERGED, np.where(stalled, Status.STALLED, Status.RUNNING))
    return np.where(work["failed"], Status.FAILED, status).astype(np.int8)


def aberth_step(log_slope: LogSlope, z: Roots) -> Roots:
    """Every root's Aberth correction at once (one evaluation of f'/f); not finite where f'/f is not."""
    newton = 1.0 / log_slope(z)
    others = 1.0 / (z[:, None] - z[None, :])
    np.fill_diagonal(others, 0.0)
    return newton / (1.0 - newton * np.sum(others, axis=1))


def _closed(roots: Roots) -> bool:
    """Is every root above the axis the mirror image of one below, exactly?"""
    upper, lower = roots[roots.imag > 0], roots[roots.imag < 0].conj()
    return bool(np.array_equal(np.sort_complex(upper), np.sort_complex(lower)))

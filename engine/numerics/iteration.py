"""The one driver of vectorized iterations: many elements (brackets, roots, points) stepped
together, each stopping on its own test, in a bounded number of rounds.

Modelled on scipy's elementwise iteration driver (read, not imported: it is private): the
work is a dict of arrays whose last axis runs over the elements still iterating.  Each
round the client's ``stopped`` names every element's status (RUNNING, or why it stops);
the elements that stop are handed to ``finish`` with their status and leave the work (the
active set shrinks: later rounds evaluate only what still moves), and ``advance`` steps the
rest (it may also add elements, as a refinement that finds a second root does).  When the
rounds run out, what still runs is finished with status ROUNDS: a bound that bites is named,
never a silent stop.

Clients: the bracketed refinement of crossings and extrema (`engine.numerics.refinement`),
the bracketed roots of the delay search (`engine.numerics.bracketing`), the Aberth
polisher of roots (`engine.numerics.aberth`) and the batched Newton of the margins' and the
peaks' batch searches (`engine.margins.pole_zero.batch_search`, `batch_peaks`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

Work = dict[str, NDArray]


class Status:
    """Why an element stopped (RUNNING: it has not): small integers, compared in whole arrays
    (plain class attributes: an enum's attribute lookup cost a tenth of a margin search)."""

    RUNNING = 0
    CONVERGED = 1  # its own tolerance met
    STALLED = 2  # its correction stopped shrinking at the evaluation's noise: as good as it gets
    FAILED = 3  # a step or an evaluation that is not finite
    ROUNDS = 4  # the bound on rounds bit first


class Outcome(NamedTuple):
    """How an iteration ended: the rounds it took and how many elements the bound stopped."""

    rounds: int
    bounded: int


def elements(work: Work) -> int:
    """How many elements the work holds (the last axis of its arrays)."""
    return next(iter(work.values())).shape[-1] if work else 0


def subset(work: Work, keep: NDArray[np.bool_] | NDArray[np.intp]) -> Work:
    """The work of the elements ``keep`` selects."""
    return {key: value[..., keep] for key, value in work.items()}


def iterate(
    work: Work,
    stopped: Callable[[Work], NDArray[np.int8]],
    advance: Callable[[Work], Work],
    finish: Callable[[Work, NDArray[np.bool_], NDArray[np.int8]], None],
    rounds: int,
) -> Outcome:
    """Step ``work`` until every element has stopped or ``rounds`` steps were taken (module
    docstring); ``stopped`` may add entries to the work it is given (estimates it computed,
    for ``advance`` and ``finish`` to read).  ``finish(work, which, status)`` is handed the
    work with the elements that stop marked (``which``) and their statuses: it reads only
    what it keeps (no copy of the rest is made)."""
    for taken in range(rounds + 1):
        if elements(work) == 0:
            return Outcome(taken, 0)
        status = np.asarray(stopped(work), dtype=np.int8)
        done = status != Status.RUNNING
        if done.all():  # every element at once (the common last round): no copies
            finish(work, done, status)
            return Outcome(taken, 0)
        if done.any():
            finish(work, done, status[done])
            work = subset(work, ~done)
        if taken == rounds:
            break
        work = advance(work)
    left = elements(work)
    finish(work, np.ones(left, dtype=bool), np.full(left, Status.ROUNDS, dtype=np.int8))
    return Outcome(rounds, left)

"""Driving a bound stepper: iterating it under a bound of steps and wall clock,
iteration 0's record, and resuming a stored run.

These are the one place each is done: the CLI, the workbench, the sweeps, the
report and `compare` all call them.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

from engine.errors import EngineError
from engine.stepping.presenter import Presenter
from engine.stepping.protocol import State, Stepper, StepRecord

TIME_LIMIT = "time limit"


class Iteration(Iterator[tuple[State, StepRecord]]):
    """The (state, record) of each step, made as they are asked for.  ``stopped`` is
    `TIME_LIMIT` once the wall-clock bound ended the iteration, else None (the
    algorithm finished, or ``max_iter`` steps were made: ``steps`` counts them).
    The clock starts at the first request and is read between steps, so at least
    one step is made; a step is never cut short, and the records made are exactly
    a prefix of the run without the limit (the state stays resumable)."""

    def __init__(self, stepper: Stepper, max_iter: int, state: State | None, time_limit: float | None) -> None:
        self.stepper, self.max_iter, self.state, self.time_limit = stepper, max_iter, state, time_limit
        self.steps = 0
        self.stopped: str | None = None
        self._began: float | None = None

    def __next__(self) -> tuple[State, StepRecord]:
        if self._began is None:
            self._began = time.perf_counter()
        if self.state is None:
            self.state = self.stepper.init()
        if self.stopped is not None or self.state.status.finished or self.steps >= self.max_iter:
            raise StopIteration
        if self.steps and self.time_limit is not None and time.perf_counter() - self._began >= self.time_limit:
            self.stopped = TIME_LIMIT
            raise StopIteration
        self.state, record = self.stepper.step(self.state)
        self.steps += 1
        return self.state, record


def iterate(
    stepper: Stepper, *, max_iter: int, state: State | None = None, time_limit: float | None = None
) -> Iteration:
    """Step (from ``state``, else from ``init()``) until the algorithm finishes, ``max_iter``
    steps were made, or ``time_limit`` seconds of wall clock have passed (checked
    between steps; the `Iteration`'s ``stopped`` is then `TIME_LIMIT`)."""
    if time_limit is not None and not time_limit >= 0:
        raise EngineError(f"time limit must be a number of seconds >= 0, not {time_limit!r}")
    return Iteration(stepper, max_iter, state, time_limit)


def first_record(presenter: Presenter, stepper: Stepper, start: State | None = None) -> StepRecord | None:
    """Iteration 0's record of a bound stepper, as its presenter gives it (``start``: its
    first state when the caller has it already); None when the loop cannot be evaluated."""
    try:
        state = stepper.init() if start is None else start
    except EngineError:
        return None
    return presenter.initial_record(stepper, state)


def resume(stepper: Stepper, stored: object | None, iteration: int) -> State:
    """The state after ``iteration`` recorded steps: the stored state read back with the
    stepper's memory type (never a re-init), or, when none is stored, the steps made
    again from the first state."""
    if iteration and stored is not None:
        return State.from_json(stored, stepper.memory_type)
    state = stepper.init()
    for _ in range(iteration):
        state, _ = stepper.step(state)
    return state

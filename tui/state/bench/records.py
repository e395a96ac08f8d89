"""The Workbench's records and undo: the session, its iterations (parsed once, kept in step
with the model), the algorithm bound to the problem and its states, undo and redo of
iterations, and the undo of edits of the problem (`tui.state.edit_history`).

This part is the one writer of the session (a test keeps it so): an edit of the problem
puts its model in place through `replace_problem`, inside `edit`, which records the undo
step; every other change (a run's iteration, an undo, an algorithm switch, a sweep kept or
adopted) is a method here.
Only the UI thread calls them."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.stepping.driver import first_record, resume
from engine.stepping.presenter import Presenter
from engine.stepping.protocol import State, Status, Stepper, StepRecord
from sessions import lifecycle
from sessions.errors import SessionError
from sessions.format.schema import ProblemModel
from sessions.hand_history import note_edit
from sessions.runner import record_json, settings_snapshot
from sessions.store import Session
from sessions.sweeps.results import adopt_run, record_sweep
from tui.state.bench.persistence import SessionFile
from tui.state.edit_history import EditHistory, Snapshot

Result = TypeVar("Result")


class RecordBook:
    """One session's records, its stepper and the undo of iterations and edits."""

    def __init__(self, session: Session, file: SessionFile) -> None:
        self.session = session
        self._file = file  # told of every change (unsaved; an iteration kept is autosaved)
        self._states: dict[int, State] = {}
        self._stepper: Stepper | None = None
        self._initial: StepRecord | None = None
        self._settings: dict | None = None
        self._records: list[StepRecord] = session.records  # parsed once, kept in step with the model
        self._redo: list[tuple[dict, StepRecord, State | None]] = []  # undone iterations, latest last
        self.edits = EditHistory()

    # -- the algorithm ------------------------------------------------------

    @property
    def algorithm_name(self) -> str:
        return self.session.model.algorithm.name

    @property
    def presenter(self) -> Presenter:
        """How the session's algorithm shows its records (the generic way when it is unknown)."""
        try:
            return lifecycle.registration(self.session).presenter
        except SessionError:
            return Presenter()

    @property
    def iteration(self) -> int:
        return self.session.model.current_iteration

    @property
    def records(self) -> list[StepRecord]:
        return self._records[: self.iteration]

    def parsed_records(self) -> list[StepRecord]:
        """Every parsed record, as an edit's snapshot keeps them (`edit_history.Snapshot`)."""
        return list(self._records)

    def status(self) -> Status:
        records = self.records
        return records[-1].status if records else Status.RUNNING

    def ensure_stepper(self) -> Stepper:
        """The algorithm bound to the problem, and the state before any iteration
        (a `SessionError` says why it cannot be set up)."""
        if self._stepper is None or 0 not in self._states:
            try:
                stepper = lifecycle.stepper(self.session)
                self._states = {0: stepper.init()}
                saved = self.session.model.state
                if self.iteration and saved is not None:  # the saved state: no replay to go on
                    self._states[self.iteration] = resume(stepper, saved, self.iteration)
            except EngineError as exc:
                raise lifecycle.named_error(self.algorithm_name, exc) from None
            self._settings = settings_snapshot(stepper.settings)  # kept with every record (replay checks them)
            self._stepper, self._initial = stepper, None
        return self._stepper

    def _state(self) -> State:
        """The state after the current iteration (replayed from the nearest known one)."""
        stepper = self.ensure_stepper()
        k = self.iteration
        known = max(i for i in self._states if i <= k)
        state = self._states[known]
        for i in range(known, k):
            state, _ = stepper.step(state)
            self._states[i + 1] = state
        return state

    def begin_run(self) -> tuple[Stepper, State]:
        """What a run's worker steps: the bound stepper and the current state."""
        state = self._state()
        return self.ensure_stepper(), state

    @property
    def settings(self) -> dict | None:
        """The settings snapshot every record is kept with (`stored_json` needs it)."""
        return self._settings

    def initial_record(self) -> StepRecord | None:
        """Iteration 0 as the presenter gives it (None when the algorithm cannot be set up)."""
        try:
            stepper = self.ensure_stepper()
            if self._initial is None:
                self._initial = first_record(self.presenter, stepper, self._states[0])
        except (EngineError, SessionError):
            return None
        return self._initial

    # -- iterations ---------------------------------------------------------

    def commit(self, state: State, record: StepRecord, stored: tuple[dict, dict] | None = None) -> None:
        """Keep an iteration computed from the current state (UI thread only);
        ``stored``: its record's and state's JSON (`stored_json`), made by the worker
        that computed it, so the UI thread does not convert every iteration."""
        if record.iteration != self.iteration + 1:
            raise SessionError(f"iteration {record.iteration} does not follow iteration {self.iteration}")
        model = self.session.model
        del model.records[self.iteration :]
        del self._records[self.iteration :]
        self._redo.clear()
        record_data, state_data = stored or stored_json(state, record, self._settings)
        self._keep(record_data, record, state, state_data)

    def _keep(self, record_data: dict, record: StepRecord, state: State, state_data: dict | None = None) -> None:
        model = self.session.model
        model.records.append(record_data)
        self._records.append(record)
        model.state = state.to_json() if state_data is None else state_data
        model.current_iteration = len(model.records)
        self._states = {i: st for i, st in self._states.items() if i < model.current_iteration}
        self._states[model.current_iteration] = state
        self._file.iteration_kept()

    def step(self) -> StepRecord | None:
        """One iteration, computed and kept (None when the algorithm has finished)."""
        algorithm, state = self.begin_run()
        if state.status.finished:
            return None
        state, record = algorithm.step(state)
        self.commit(state, record)
        return record

    def undo(self) -> bool:
        """Drop the last iteration (False when there is none); `redo` brings it back."""
        model = self.session.model
        if model.current_iteration == 0:
            return False
        k = model.current_iteration
        self._redo.append((model.records[k - 1], self._records[k - 1], self._states.get(k)))
        model.current_iteration -= 1
        del model.records[model.current_iteration :]
        del self._records[model.current_iteration :]
        previous = self._states.get(model.current_iteration)
        model.state = previous.to_json() if previous is not None else None
        self._file.mark_changed()
        return True

    @property
    def can_redo(self) -> bool:
        """Whether an undone iteration can come back."""
        return bool(self._redo)

    def redo(self) -> bool:
        """Bring back the latest undone iteration (False when there is none)."""
        if not self._redo:
            return False
        data, record, state = self._redo.pop()
        if state is None:
            state, _ = self.ensure_stepper().step(self._state())
        self._keep(data, record, state)
        return True

    def start_from(self, iteration: int) -> None:
        """Make an earlier iteration the current one (later records are dropped)."""
        if not 0 <= iteration <= self.iteration:
            raise SessionError(f"iteration {iteration} is outside 0..{self.iteration}")
        while self.iteration > iteration:
            self.undo()

    # -- changing the problem ------------------------------------------------------

    def edit(self, change: Callable[[], Result], burst: object = None) -> Result:
        """Make an edit of the problem one undo step (`EditHistory.push`; edits of one
        ``burst`` join one step): what the session held before is kept, and put back whole
        when ``change`` raises `SessionError` or `ValueError` (raised again).  An edit that
        continues a burst with no iteration recorded copies nothing (its undo step is the
        burst's first snapshot; a burst's changes are transactions, `tui.state.edits`, which
        put nothing in place when refused, and with no iteration none is adopted first): a
        copy of the session's problem each nudge, 1-3 ms, dropped at once."""
        before = None if self.iteration == 0 and self.edits.continues(burst) else Snapshot.of(self)
        try:
            result = change()
        except (SessionError, ValueError):
            if before is not None:
                self.restore(before)
            raise
        self.edits.push(before, self, burst)
        return result

    def replace_problem(self, model: ProblemModel, problem: Problem) -> None:
        """The session's problem made ``model`` and the engine problem built from it (the
        edits' one way in: `tui.state.edits.transaction`); a change of parameter values alone
        is noted as a hand move (`hand_history.note_edit`); the records are dropped."""
        before = self.session.model.problem
        self.session.model.problem, self.session.problem = model, problem
        note_edit(self.session, before)
        self.reset()

    def replace_settings(self, settings: dict) -> None:
        """The algorithm's settings made ``settings`` (checked by the caller); the records are dropped."""
        self.session.model.algorithm.settings = settings
        self.reset()

    def restore(self, snapshot: Snapshot) -> None:
        """Put back what a snapshot kept (an edit undone, or refused)."""
        model = self.session.model
        model.problem = snapshot.problem_model.model_copy(deep=True)
        model.algorithm = snapshot.algorithm.model_copy(deep=True)
        model.records[:] = snapshot.records
        model.current_iteration, model.state = snapshot.current_iteration, snapshot.state
        model.earlier[:] = snapshot.earlier
        self.session.problem = snapshot.problem
        self.forget_stepper()
        self._records[:] = snapshot.parsed_records
        self._redo.clear()  # the iterations undone before belonged to the state left
        self._file.mark_changed()

    def adopt_run(self, run: dict) -> list[str]:
        """A sweep's run (its design) becomes the start (the records are dropped); the design
        bounds widened to hold it, one line each (`sessions.sweeps.results.adopt_run`)."""
        widened = adopt_run(self.session, run)
        self.reset()
        return widened

    def keep_sweep(self, summary: dict) -> None:
        """Record a sweep's summary in the session (`sessions.sweeps.results.record_sweep`)."""
        record_sweep(self.session, summary)
        self._file.mark_changed()

    def adopt_current(self) -> None:
        """The current iteration's design becomes the start (the records are dropped)."""
        lifecycle.adopt_current(self.session)
        self.reset()

    def set_algorithm(self, name: str) -> None:
        lifecycle.switch_algorithm(self.session, name)
        self.reset()

    def reset(self) -> None:
        """Forget every record (the problem or the algorithm changed)."""
        lifecycle.forget_records(self.session)
        self._records.clear()
        self._redo.clear()
        self.forget_stepper()
        self._file.mark_changed()

    def forget_stepper(self) -> None:
        """Set the algorithm up again on next use (the problem or its settings changed)."""
        self._states, self._stepper, self._initial = {}, None, None


def stored_json(state: State, record: StepRecord, settings: dict | None) -> tuple[dict, dict]:
    """A step's record and state as the session keeps them (any thread: both are immutable)."""
    return record_json(record, settings), state.to_json()

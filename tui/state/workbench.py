"""The workbench's model, free of widgets: one open session, its algorithm,
stepping, undo, choosing an earlier iteration as the new start, sweeps.

Only the UI thread calls the methods that change the session (`commit`,
`undo`, `reset`, edits).  A run's worker gets what it needs from
`begin_run` (the algorithm and the current state) and computes; the app
commits each record it posts back.  What the screens show comes from
`view()`, a read-only snapshot (`tui.state.views`).
"""

from __future__ import annotations

from pathlib import Path

from numpy.typing import NDArray

from engine.closed_loop.step_response import StepSetup
from engine.design.constraints import ConstraintState, binding, constraint_states
from engine.design.notes import at_bounds, noise_notes, stop_notes
from engine.errors import EngineError
from engine.stepping.driver import first_record, resume
from engine.stepping.presenter import Presenter
from engine.stepping.protocol import State, Status, Stepper, StepRecord
from sessions import lifecycle
from sessions.errors import SessionError
from sessions.runner import record_json, settings_snapshot
from sessions.store import AUTOSAVE_INTERVAL, Session, autosave_path, save_session, write_autosave
from tui.state.edit_history import EditHistory
from tui.state.sweep_desk import SweepDesk
from tui.state.views import View


class Workbench:
    """One open session and its algorithm."""

    def __init__(self, session: Session) -> None:
        self.session = session
        self.dirty = False
        self.untitled = False  # a new session, not yet saved under a name of the user's: its first save asks one
        self._states: dict[int, State] = {}
        self._stepper: Stepper | None = None
        self._initial: StepRecord | None = None
        self._settings: dict | None = None
        self._records: list[StepRecord] = session.records  # parsed once, kept in step with the model
        self.plotted_condition: int | None = None  # the flight condition the plots show; None: all
        self.plotted_break: str | None = None  # the break the loop plots draw (view state); None: the primary
        self.edits = EditHistory()
        self.paused_at: int | None = None  # the iteration a run was paused at
        # the start after an edit that drops iterations: "design" (the one on screen), "saved"
        # (the session's saved start), None (not asked yet: the first such edit asks)
        self.start: str | None = None
        self.step_setup = StepSetup()  # the step plot's input, output and horizon
        self._redo: list[tuple[dict, StepRecord, State | None]] = []  # undone iterations, latest last
        self.sweeps = SweepDesk(self)  # the session's sweeps: the latest, running one, adopting from it
        # a finished record's noise notes, with the problem and the record they are of
        self._noise: tuple[object, object, list[str]] = (None, None, [])

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

    def put_back(self, parsed: list[StepRecord]) -> None:
        """Records an edit's undo brings back; the iterations undone before it are forgotten
        (their redo belonged to the state left)."""
        self._records[:] = parsed
        self._redo.clear()

    def status(self) -> Status:
        records = self.records
        return records[-1].status if records else Status.RUNNING

    def status_text(self) -> str:
        records = self.records
        if not records:
            return "not started"
        last = records[-1]
        if self.paused_at == self.iteration and not last.status.finished:
            return "paused (s steps on, r runs on)"
        if not last.status.finished:  # the record's status says the algorithm goes on, not that it runs now
            return "not finished" + (f": {last.reason}" if last.reason else "") + " (s steps on, r runs on)"
        why = stop_notes(self.session.problem, last.status, dict(last.parameters), last.measures)
        return last.status.value + (f": {last.reason}" if last.reason else "") + "".join(f"; {n}" for n in why)

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
        self.dirty = True
        write_autosave(self.session, at_most_every=AUTOSAVE_INTERVAL, wait=False)

    def step(self) -> StepRecord | None:
        """One iteration, computed and kept (None when the algorithm has finished)."""
        algorithm, state = self.begin_run()
        if state.status.finished:
            return None
        state, record = algorithm.step(state)
        self.commit(state, record)
        return record

    def autosave(self, throttled: bool = False, wait: bool = True) -> str:
        """Write the autosave of unsaved changes (``throttled``: at most every
        AUTOSAVE_INTERVAL, as runs do; ``wait``: for the write, else it goes on in the
        background, in order); says where, or why it could not."""
        if not self.dirty:
            return "nothing unsaved"
        if self.session.path is None:
            return "no autosave (the session has no file yet)"
        write_autosave(self.session, at_most_every=AUTOSAVE_INTERVAL if throttled else 0.0, wait=wait)
        if not wait:
            return f"autosaving to {autosave_path(self.session.path).name}"
        if self.session.autosave_warning:
            return f"the autosave failed: {self.session.autosave_warning}"
        return f"autosaved to {autosave_path(self.session.path).name}"

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
        self.dirty = True
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
        self.dirty = True
        return True

    # -- changing the problem ------------------------------------------------------

    def start_from(self, iteration: int) -> None:
        """Make an earlier iteration the current one (later records are dropped)."""
        if not 0 <= iteration <= self.iteration:
            raise SessionError(f"iteration {iteration} is outside 0..{self.iteration}")
        while self.iteration > iteration:
            self.undo()

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
        self.dirty = True

    def forget_stepper(self) -> None:
        """Set the algorithm up again on next use (the problem or its settings changed)."""
        self._states, self._stepper, self._initial = {}, None, None

    def rebuild(self) -> None:
        """Rebuild the engine problem after an edit of the model (a `SessionError` when it
        does not build: the caller keeps the old model, see `tui.editing.transaction`)."""
        lifecycle.rebuild(self.session)
        self.reset()

    def save(self, path: str | Path | None = None, force: bool = False) -> Path:
        """Save (``force``: over a file changed on disk since it was loaded, or a read-only one)."""
        target = save_session(self.session, path, force=force)
        self.dirty = False
        self.untitled = self.untitled and path is None
        return target

    # -- what the screens show ---------------------------------------------

    def initial_record(self) -> StepRecord | None:
        """Iteration 0 as the presenter gives it (None when the algorithm cannot be set up)."""
        try:
            stepper = self.ensure_stepper()
            if self._initial is None:
                self._initial = first_record(self.presenter, stepper, self._states[0])
        except (EngineError, SessionError):
            return None
        return self._initial

    def design_notes(self, record: StepRecord) -> list[str]:
        """The notes on a record's design: the constraints that bind and its parameters at a
        bound after every step; once the algorithm has finished, its compensator's noise
        amplification too (a margin search: made once per finished record, `engine.design.notes`)."""
        values = dict(record.parameters)
        problem = self.session.problem
        notes = self._binding(values) + at_bounds(problem, values)
        if record.status.finished:
            noted, kept = self._noise[:2]
            if noted is not problem or kept is not record:  # the objects held, not their ids
                self._noise = (problem, record, noise_notes(problem, values))
            notes += self._noise[2]
        return notes

    def constraint_states(self) -> list[ConstraintState]:
        """Each linear constraint at the current design (the last record's, else the start); none
        when the records no longer fit the problem (a parameter renamed since)."""
        problem = self.session.problem
        x = self._vector(dict(self.records[-1].parameters) if self.records else {})
        return [] if x is None else constraint_states(problem, x)

    def _binding(self, values: dict) -> list[str]:
        """The constraints that bind at a record's values (none when they no longer fit the problem)."""
        x = self._vector(values)
        return [] if x is None else binding(self.session.problem, x)

    def _vector(self, values: dict) -> NDArray | None:
        """The problem's free vector at named values; None when they no longer fit it (a
        parameter renamed since the record was made)."""
        try:
            return self.session.problem.vector_from(values)
        except EngineError:
            return None

    def view(self) -> View:
        """A read-only snapshot of what the screens show now."""
        return View(
            self.session.problem,
            tuple(self.records),
            self.presenter,
            self.initial_record(),
            self.plotted_condition,
            self.step_setup,
            self.plotted_break,
        )

    def next_plotted_condition(self) -> str:
        """Cycle the plots through every condition together and each alone; says what they show now."""
        names = [c.name for c in self.session.problem.conditions]
        if len(names) < 2:
            self.plotted_condition = None
            return "the session has one flight condition"
        k = self.plotted_condition
        self.plotted_condition = 0 if k is None else None if k + 1 >= len(names) else k + 1
        return (
            "plots: every flight condition"
            if self.plotted_condition is None
            else f"plots: {names[self.plotted_condition]} (current and initial)"
        )

    def break_choices(self) -> list[str]:
        """The breaks the loop plots can be drawn at, in the conditions' order (every
        condition's breaks, the primary ones first)."""
        conditions = self.session.problem.conditions
        primary = [c.break_at for c in conditions]
        return list(dict.fromkeys(primary + [b for c in conditions for b in c.every_break]))

    def break_refusal(self) -> str | None:
        """Why the loop plots have no other break to draw (None: they have)."""
        if len(self.break_choices()) > 1:
            return None
        return "one loop break: no flight condition names other breaks (conditions[k].breaks)"

    def next_plotted_break(self) -> str:
        """The loop plots drawn at the next break (after the last, each condition's primary
        break again); says what they show now."""
        choices = self.break_choices()
        if len(choices) < 2:
            self.plotted_break = None
            return self.break_refusal() or ""
        k = choices.index(self.plotted_break) if self.plotted_break in choices else 0
        self.plotted_break = None if k + 1 >= len(choices) else choices[k + 1]
        conditions = self.session.problem.conditions
        if self.plotted_break is None:
            return f"Bode, Nyquist, Nichols: the loop at {', '.join(dict.fromkeys(c.break_at for c in conditions))}"
        lacking = [c.name for c in conditions if self.plotted_break not in c.every_break]
        aside = f" ({', '.join(lacking)}: at its primary break)" if lacking else ""
        return f"Bode, Nyquist, Nichols: the loop at {self.plotted_break}, the other loops closed{aside}"


def stored_json(state: State, record: StepRecord, settings: dict | None) -> tuple[dict, dict]:
    """A step's record and state as the session keeps them (any thread: both are immutable)."""
    return record_json(record, settings), state.to_json()

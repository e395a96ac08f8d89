"""The workbench's model, free of widgets: one open session wired to its parts (its records
and their undo, `tui.state.bench.records`; its file, `tui.state.bench.persistence`; its
sweeps, `tui.state.sweep_desk`) and what the screens show of it.

Only the UI thread calls the methods that change the session (`commit`,
`undo`, `reset`, edits).  A run's worker gets what it needs from
`begin_run` (the algorithm and the current state) and computes; the app
commits each record it posts back.  What the screens show comes from
`view()`, a read-only snapshot (`tui.state.views`).
"""

from __future__ import annotations

from numpy.typing import NDArray

from engine.closed_loop.step_response import StepSetup
from engine.design.constraints import ConstraintState, binding, constraint_states
from engine.design.notes import at_bounds, noise_notes, stop_notes
from engine.errors import EngineError
from engine.stepping.protocol import State, Status, Stepper, StepRecord
from sessions.store import Session
from tui.state.bench.persistence import SessionFile
from tui.state.bench.records import RecordBook
from tui.state.edit_history import EditHistory
from tui.state.sweep_desk import SweepDesk
from tui.state.views import View


class Workbench:
    """One open session, wired to its parts: ``book`` (records and undo), ``file``
    (saving), ``sweeps``; and the view state the screens choose."""

    def __init__(self, session: Session, untitled: bool = False) -> None:
        self.file = SessionFile(session, untitled)
        self.book = RecordBook(session, self.file)
        self.sweeps = SweepDesk(self)  # the session's sweeps: the latest, running one, adopting from it
        self.plotted_condition: int | None = None  # the flight condition the plots show; None: all
        self.plotted_break: str | None = None  # the break the loop plots draw (view state); None: the primary
        self.paused_at: int | None = None  # the iteration a run was paused at
        # the start after an edit that drops iterations: "design" (the one on screen), "saved"
        # (the session's saved start), None (not asked yet: the first such edit asks)
        self.start: str | None = None
        self.step_setup = StepSetup()  # the step plot's input, output and horizon
        # a finished record's noise notes, with the problem and the record they are of
        self._noise: tuple[object, object, list[str]] = (None, None, [])

    # -- the parts, as the screens and the tests read them ----------------------------

    @property
    def session(self) -> Session:
        return self.book.session

    @property
    def edits(self) -> EditHistory:
        return self.book.edits

    @property
    def dirty(self) -> bool:
        return self.file.dirty

    @dirty.setter
    def dirty(self, value: bool) -> None:
        self.file.dirty = value

    @property
    def untitled(self) -> bool:
        return self.file.untitled

    @untitled.setter
    def untitled(self, value: bool) -> None:
        self.file.untitled = value

    @property
    def algorithm_name(self) -> str:
        return self.book.algorithm_name

    @property
    def iteration(self) -> int:
        return self.book.iteration

    @property
    def records(self) -> list[StepRecord]:
        return self.book.records

    @property
    def can_redo(self) -> bool:
        return self.book.can_redo

    def status(self) -> Status:
        return self.book.status()

    @property
    def settings(self) -> dict | None:
        return self.book.settings

    def begin_run(self) -> tuple[Stepper, State]:
        return self.book.begin_run()

    def commit(self, state: State, record: StepRecord, stored: tuple[dict, dict] | None = None) -> None:
        self.book.commit(state, record, stored)

    def step(self) -> StepRecord | None:
        return self.book.step()

    def undo(self) -> bool:
        return self.book.undo()

    def redo(self) -> bool:
        return self.book.redo()

    def start_from(self, iteration: int) -> None:
        self.book.start_from(iteration)

    def set_algorithm(self, name: str) -> None:
        self.book.set_algorithm(name)

    def ensure_stepper(self) -> Stepper:
        return self.book.ensure_stepper()

    def initial_record(self) -> StepRecord | None:
        return self.book.initial_record()

    def status_text(self, hints: bool = True) -> str:
        """Where the algorithm stands (``hints``: with the keys that go on, where it has not finished)."""
        records = self.records
        if not records:
            return "not started"
        last = records[-1]
        hint = " (s steps on, r runs on)" if hints else ""
        if self.paused_at == self.iteration and not last.status.finished:
            return "paused" + hint
        if not last.status.finished:  # the record's status says the algorithm goes on, not that it runs now
            return "not finished" + (f": {last.reason}" if last.reason else "") + hint
        why = stop_notes(self.session.problem, last.status, dict(last.parameters), last.measures)
        return last.status.value + (f": {last.reason}" if last.reason else "") + "".join(f"; {n}" for n in why)

    # -- what the screens show ---------------------------------------------

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
            self.book.presenter,
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

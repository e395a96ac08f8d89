"""The workbench's model, free of widgets: a session, its algorithm, stepping,
undo, choosing an earlier iteration as the new start, and the data the
plots and tableaux show.  The app drives it from a worker thread and renders
what it returns; tests drive it directly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.algorithm import MeasureRow, State, Status, StepRecord, lookup, make_settings
from engine.errors import EngineError
from engine.loops import loop_model, open_loop
from engine.margins import Margins, margins
from engine.realization import realize
from engine.timeresp import Segment, simulate
from sessions.build import build_problem
from sessions.errors import SessionError
from sessions.store import AUTOSAVE_INTERVAL, Session, save_session, write_autosave
from sessions.sweeps import adopt_run, execute, parse_sweep, plan, record_sweep, summarize


@dataclass(frozen=True)
class LoopCurve:
    """GH(j omega) of one condition at some parameters (for Nyquist, Bode, Nichols)."""

    omega: np.ndarray
    gh: np.ndarray
    label: str
    color: str = "blue"
    margins: Margins | None = None   # marked on the Bode plots (the current design's curves)


CONDITION_COLORS = ("blue", "orange", "magenta", "cyan", "green", "yellow", "red")
INITIAL_COLOR = "gray"


class Workbench:
    """One open session and its algorithm."""

    def __init__(self, session: Session):
        self.session = session
        self.dirty = False
        self._states: dict[int, State] = {}
        self._algorithm = None
        self._records: list[StepRecord] = session.records   # parsed once, kept in step with the model
        self.plotted_condition: int | None = None   # the flight condition the plots show; None: all

    # -- the algorithm ------------------------------------------------------

    @property
    def algorithm_name(self) -> str:
        return self.session.model.algorithm.name

    @property
    def iteration(self) -> int:
        return self.session.model.current_iteration

    @property
    def records(self) -> list[StepRecord]:
        return self._records[:self.iteration]

    def status(self) -> Status:
        records = self.records
        return records[-1].status if records else Status.RUNNING

    def status_text(self) -> str:
        records = self.records
        if not records:
            return "not started"
        last = records[-1]
        return last.status.value + (f": {last.reason}" if last.reason else "")

    def _algorithm_and_settings(self):
        try:
            settings = make_settings(self.algorithm_name, self.session.model.algorithm.settings)
            return lookup(self.algorithm_name).factory(), settings
        except (EngineError, TypeError) as exc:
            raise SessionError(f"algorithm: {exc}") from None

    def ensure_algorithm(self):
        """The algorithm bound to the problem, and the state before any iteration
        (a `SessionError` says why it cannot be set up)."""
        if self._algorithm is None or 0 not in self._states:
            algorithm, settings = self._algorithm_and_settings()
            try:
                self._states = {0: algorithm.init(self.session.problem, settings)}
            except EngineError as exc:
                raise SessionError(f"{self.algorithm_name}: {exc}") from None
            self._algorithm = algorithm
        return self._algorithm

    def _state(self) -> State:
        """The state after the current iteration (replayed from the nearest known one)."""
        algorithm = self.ensure_algorithm()
        k = self.iteration
        known = max(i for i in self._states if i <= k)
        state = self._states[known]
        for i in range(known, k):
            state, _ = algorithm.step(state)
            self._states[i + 1] = state
        return state

    def step(self) -> StepRecord | None:
        """One iteration (None when the algorithm has finished)."""
        state = self._state()
        if state.status.finished:
            return None
        state, record = self._algorithm.step(state)
        model = self.session.model
        del model.records[self.iteration:]
        model.records.append(record.to_json())
        del self._records[self.iteration:]
        self._records.append(record)
        model.state = state.to_json()
        model.current_iteration = len(model.records)
        self._states = {i: st for i, st in self._states.items() if i < model.current_iteration}
        self._states[model.current_iteration] = state
        self.dirty = True
        write_autosave(self.session, at_most_every=AUTOSAVE_INTERVAL)
        return record

    def autosave(self) -> None:
        """Write the autosave now (at the end of a run)."""
        if self.dirty:
            write_autosave(self.session)

    def undo(self) -> bool:
        """Drop the last iteration (False when there is none)."""
        model = self.session.model
        if model.current_iteration == 0:
            return False
        model.current_iteration -= 1
        del model.records[model.current_iteration:]
        del self._records[model.current_iteration:]
        previous = self._states.get(model.current_iteration)
        model.state = previous.to_json() if previous is not None else None
        self.dirty = True
        return True

    # -- sweeps ----------------------------------------------------------------

    def latest_sweep(self) -> dict | None:
        """The session's most recent sweep (JSON data), if any."""
        sweeps = self.session.model.sweeps
        return sweeps[-1].model_dump() if sweeps else None

    def run_sweep(self, text: str, progress=None, cancelled=lambda: False) -> dict:
        """Plan and run a sweep described by one line (`sessions.sweeps.parse_sweep`);
        safe in a worker thread (the session is only read).  The summary is returned,
        not yet kept: `keep_sweep` does that on the UI thread."""
        spec = parse_sweep(text)
        jobs, settings = plan(self.session, spec["kind"], spec["value"], spec.get("spread"), spec.get("seed", 0),
                              spec.get("samples", 32))
        settings["scheduler"] = spec["scheduler"] or "local"
        outcome = execute(jobs, spec["scheduler"], progress=progress, cancelled=cancelled)
        return summarize(self.session, spec["kind"], settings, outcome)

    def keep_sweep(self, summary: dict) -> None:
        record_sweep(self.session, summary)
        self.dirty = True

    def adopt_best(self) -> dict:
        """Make the latest sweep's best optimum the start (records dropped); its run."""
        sweep = self.latest_sweep()
        if not sweep or not sweep["optima"]:
            raise SessionError("no sweep with a finished run to adopt")
        run = sweep["runs"][sweep["optima"][0]["best_run"]]
        adopt_run(self.session, run)
        self.reset()
        return run

    def start_from(self, iteration: int) -> None:
        """Make an earlier iteration the current one (later records are dropped)."""
        if not 0 <= iteration <= self.iteration:
            raise SessionError(f"iteration {iteration} is outside 0..{self.iteration}")
        while self.iteration > iteration:
            self.undo()

    def set_algorithm(self, name: str) -> None:
        lookup(name)
        self.session.model.algorithm.name = name
        self.session.model.algorithm.settings = {}
        self.reset()

    def reset(self) -> None:
        """Forget every record (the problem or the algorithm changed)."""
        model = self.session.model
        model.records.clear()
        self._records.clear()
        model.current_iteration = 0
        model.state = None
        self._states, self._algorithm = {}, None
        self.dirty = True

    def rebuild(self) -> None:
        """Rebuild the engine problem after an edit of the model; on error the
        caller restores the old value (nothing is lost)."""
        folder = self.session.path.parent if self.session.path else Path.cwd()
        self.session.problem = build_problem(self.session.model.problem, folder)
        self.reset()

    def save(self, path: str | Path | None = None) -> Path:
        target = save_session(self.session, path)
        self.dirty = False
        return target

    # -- what the screens show ---------------------------------------------

    def tableau(self, iteration: int | None = None) -> tuple[list[MeasureRow], StepRecord | None]:
        k = self.iteration if iteration is None else iteration
        if k == 0:
            record = self.initial_record()
            return (list(record.measures) if record else []), record
        record = self.records[k - 1]
        return list(record.measures), record

    def initial_record(self) -> StepRecord | None:
        """Iteration 0 as a record, where the algorithm offers one (cip's initial tableau)."""
        try:
            algorithm = self.ensure_algorithm()
        except (EngineError, SessionError):
            return None
        if not hasattr(algorithm, "initial_record"):
            return None
        return algorithm.initial_record(self._states[0])

    def parameters(self, iteration: int | None = None, condition: int = 0) -> dict[str, float]:
        """Parameter values one condition sees after an iteration (0: the session's start)."""
        k = self.iteration if iteration is None else iteration
        problem = self.session.problem
        return problem.values_with(self.records[k - 1].parameters, condition) if k > 0 else problem.values(condition)

    def loop_curve(self, iteration: int | None = None, label: str = "current", condition: int = 0,
                   color: str = "blue") -> LoopCurve | None:
        """GH of one condition (None when the loop cannot be evaluated)."""
        problem = self.session.problem
        if condition >= len(problem.conditions):
            return None
        c = problem.conditions[condition]
        values = self.parameters(iteration, condition)
        try:
            response = open_loop(c.network, c.break_at, problem.grid.omega, values, sensitivities=False)
        except EngineError:
            return None
        found = None
        if iteration is None:
            try:
                found = margins(loop_model(c.network, c.break_at, problem.grid.omega, values))
            except EngineError:
                pass
        return LoopCurve(problem.grid.omega, response.value, label, color, found)

    def plotted(self) -> list[int]:
        """The conditions the plots show (`plotted_condition`; every one when None)."""
        count = len(self.session.problem.conditions)
        if self.plotted_condition is not None and self.plotted_condition < count:
            return [self.plotted_condition]
        return list(range(count))

    def next_plotted_condition(self) -> str:
        """Cycle the plots through every condition together and each alone; says what they show now."""
        names = [c.name for c in self.session.problem.conditions]
        if len(names) < 2:
            self.plotted_condition = None
            return "the session has one flight condition"
        k = self.plotted_condition
        self.plotted_condition = 0 if k is None else None if k + 1 >= len(names) else k + 1
        return "plots: every flight condition" if self.plotted_condition is None else \
            f"plots: {names[self.plotted_condition]} (current and initial)"

    def shown(self, iteration: int | None = None) -> list[tuple[int | None, int, str, str]]:
        """What the plots draw for an iteration (None: the current one), as
        (iteration or None for the current, condition, label, colour): each
        plotted condition, labelled by name, when there are several; one
        condition alone also with a reference: the initial design beside the
        current one, the current design beside an earlier iteration."""
        conditions = self.session.problem.conditions
        plotted = self.plotted()
        k_it = self.iteration if iteration is None else iteration
        at = None if k_it == self.iteration else k_it
        if len(plotted) > 1:
            return [(at, k, conditions[k].name, CONDITION_COLORS[k % len(CONDITION_COLORS)]) for k in plotted]
        if not plotted:
            return []
        k = plotted[0]
        prefix = f"{conditions[k].name}: " if len(conditions) > 1 else ""
        wanted = [(at, k, prefix + ("current" if at is None else f"iteration {k_it}" if k_it else "start"), "blue")]
        if at is not None:
            wanted.append((None, k, prefix + "current", INITIAL_COLOR))
        elif self.iteration:
            wanted.append((0, k, prefix + "initial", INITIAL_COLOR))
        return wanted

    def loop_curves(self, iteration: int | None = None) -> list[LoopCurve]:
        """The open loops the plots draw (`shown`)."""
        curves = [self.loop_curve(at, label, k, color) for at, k, label, color in self.shown(iteration)]
        return [c for c in curves if c is not None]

    def step_response(self, iteration: int | None = None,
                      condition: int = 0) -> tuple[list[float], list[float], str] | None:
        """Closed-loop response to a unit step at the first input, of the output signal
        (y, c or x1 when present), for rational plants; None otherwise."""
        problem = self.session.problem
        if condition >= len(problem.conditions) or not problem.conditions[condition].network.rational:
            return None
        network = problem.conditions[condition].network
        try:
            ss = realize(network, self.parameters(iteration, condition))
        except EngineError:
            return None
        if not ss.inputs or ss.A.size == 0:
            return None
        output = next((name for name in ("y", "c", "x1") if name in ss.outputs), ss.outputs[-1])
        real = np.linalg.eigvals(ss.A).real
        slowest = np.abs(real[real < 0]).min(initial=np.inf)
        horizon = 5.0 / real.max() if real.max() > 0 else min(8.0 / slowest, 1e4) if np.isfinite(slowest) else 10.0
        t = np.linspace(0.0, horizon, 400)
        try:
            y = simulate(ss, ss.inputs[0], t, [Segment(0.0, step=1.0)])[:, ss.outputs.index(output)]
        except EngineError:
            return None
        return t.tolist(), y.tolist(), f"{output} (step at {ss.inputs[0]})"

    def step_traces(self) -> tuple[str, list[tuple[list[float], list[float], str, str]]]:
        """The step responses the plot draws (`shown`): what is plotted, and
        (t, y, label, colour) per trace."""
        name, traces = "", []
        for at, k, label, color in self.shown():
            response = self.step_response(at, k)
            if response is not None:
                t, y, name = response
                traces.append((t, y, label, color))
        return name, traces

    def trajectories(self) -> tuple[list[float], list[list[float]], list[list[float]]] | None:
        """t, x(t), u(t) of the current iteration (algorithms that produce trajectories)."""
        records = self.records
        if not records or "u" not in records[-1].extra:
            return None
        e = records[-1].extra
        return e["t"], e["x"], e["u"]

    def convergence(self) -> tuple[str, list[int], list[float]]:
        """The convergence curve: what it measures, iterations, values."""
        records = self.records
        if not records:
            return "", [], []
        if "smallest_stability_margin" in records[0].extra:
            label, values = "smallest stability margin", [r.extra.get("smallest_stability_margin") for r in records]
        elif "distance" in records[0].extra:
            label, values = "log10 distance between the sets", [math.log10(max(r.extra["distance"], 1e-300))
                                                                 for r in records]
        elif records[0].objective is not None:
            label, values = "cost", [r.objective for r in records]
        else:
            label, values = "unmet targets", [sum(not m.satisfied for m in r.measures) for r in records]
        points = [(r.iteration, float(v)) for r, v in zip(records, values) if v is not None and math.isfinite(v)]
        return label, [p[0] for p in points], [p[1] for p in points]

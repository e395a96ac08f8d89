"""What the workbench's plots and tableaux show, as a read-only snapshot.

A `View` holds the problem, the records up to the current iteration, the
algorithm's presenter and iteration 0's record; it never changes.  The UI
thread takes one from the `Workbench` (`Workbench.view()`), and a run's
worker extends its own copy with each record it computes (`View.extended`)
to draw the figures off the UI thread while the UI thread alone changes the
session (docs/architecture.md, "The run loop").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from engine.analysis import LoopCurve, loop_curve
from engine.closed_loop.step_response import StepSetup, has_delays, horizon, network_step, realized
from engine.closed_loop.tabulated_step import has_tables
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.stepping.presenter import tolerant
from engine.stepping.protocol import MeasureRow, StepRecord


@dataclass(frozen=True)
class View:
    """The session as the screens show it at one moment."""

    problem: Problem
    records: tuple[StepRecord, ...]
    presenter: Any
    initial: StepRecord | None = None  # iteration 0's record (the presenter's)
    plotted_condition: int | None = None  # the flight condition the plots show; None: all
    step_setup: StepSetup = StepSetup()  # the step plot's input, output and horizon
    plotted_break: str | None = None  # the break whose Bode, Nyquist and Nichols are drawn; None: each primary

    @property
    def iteration(self) -> int:
        return len(self.records)

    def extended(self, record: StepRecord) -> View:
        """The view after one more iteration."""
        return replace(self, records=self.records + (record,))

    def record(self, iteration: int | None = None) -> StepRecord | None:
        """The record of an iteration (None: the current one; 0: iteration 0's)."""
        k = self.iteration if iteration is None else iteration
        return self.records[k - 1] if k > 0 else self.initial

    def tableau(self, iteration: int | None = None) -> tuple[list[MeasureRow], StepRecord | None]:
        """The rows of an iteration's tableau and its record."""
        record = self.record(iteration)
        return (list(record.measures) if record else []), record

    def parameters(self, iteration: int | None = None, condition: int = 0) -> dict[str, float]:
        """Parameter values one condition sees after an iteration (0: the session's start)."""
        k = self.iteration if iteration is None else iteration
        named = self.records[k - 1].parameters if k > 0 else None
        return self.problem.condition_values(condition, named=named)

    def loop_curve(
        self,
        iteration: int | None = None,
        label: str = "current",
        condition: int = 0,
        role: str = "current",
        with_margins: bool = True,
        points: int | None = None,
    ) -> LoopCurve | None:
        """GH of one condition (None when the loop cannot be evaluated); the current one with
        its margins (``with_margins``: a tabulated loop's margins are a rational fit's); on
        ``points`` of the grid's frequencies, evenly spread along it with both ends (None: all)."""
        problem = self.problem
        if condition >= len(problem.conditions):
            return None
        c = problem.conditions[condition]
        values = self.parameters(iteration, condition)
        marked = iteration is None and with_margins
        omega = problem.grid.omega
        if points is not None and points < omega.size:
            omega = omega[np.unique(np.linspace(0, omega.size - 1, points).round().astype(int))]
        try:
            return loop_curve(c.network, self.break_of(condition), omega, values, label, role, condition, marked)
        except EngineError:
            return None

    def break_of(self, condition: int) -> str:
        """The break the loop plots draw in a condition: the chosen one (`plotted_break`) where
        the condition names it among its breaks, else the condition's primary break."""
        c = self.problem.conditions[condition]
        return self.plotted_break if self.plotted_break in c.every_break else c.break_at

    def at_chosen_break(self) -> bool:
        """Whether the loop plots draw another loop than the primary break's (a break chosen
        that a plotted condition names)."""
        return any(self.break_of(k) != self.problem.conditions[k].break_at for k in self.plotted())

    def break_title(self) -> str:
        """What the loop plots' titles say of the break: ' at NAME' when a plotted condition
        has several breaks (each condition's break when they differ), '' otherwise."""
        conditions = self.problem.conditions
        plotted = [k for k in self.plotted() if conditions[k].several_breaks]
        names = list(dict.fromkeys(self.break_of(k) for k in plotted))
        return f" at {', '.join(names)}" if names else ""

    def plotted(self) -> list[int]:
        """The conditions the plots show (`plotted_condition`; every one when None)."""
        count = len(self.problem.conditions)
        if self.plotted_condition is not None and self.plotted_condition < count:
            return [self.plotted_condition]
        return list(range(count))

    @property
    def first_plotted(self) -> int:
        """The first condition the plots show (0 when the session has none)."""
        plotted = self.plotted()
        return plotted[0] if plotted else 0

    def shown(self, iteration: int | None = None) -> list[tuple[int | None, int, str, str]]:
        """What the plots draw for an iteration (None: the current one), as
        (iteration or None for the current, condition, label, role): each
        plotted condition, labelled by name, when there are several; one
        condition alone also with a reference: the initial design beside the
        current one, the current design beside an earlier iteration."""
        conditions = self.problem.conditions
        plotted = self.plotted()
        k_it = self.iteration if iteration is None else iteration
        at = None if k_it == self.iteration else k_it
        if len(plotted) > 1:
            return [(at, k, conditions[k].name, "condition") for k in plotted]
        if not plotted:
            return []
        k = plotted[0]
        prefix = f"{conditions[k].name}: " if len(conditions) > 1 else ""
        wanted = [(at, k, prefix + ("current" if at is None else f"iteration {k_it}" if k_it else "start"), "current")]
        if at is not None:
            wanted.append((None, k, prefix + "current", "reference"))
        elif self.iteration:
            wanted.append((0, k, prefix + "initial", "reference"))
        return wanted

    def loop_curves(
        self, iteration: int | None = None, with_margins: bool = True, points: int | None = None
    ) -> list[LoopCurve]:
        """The open loops the plots draw (`shown`), the current one's with its margins (on
        ``points`` of the grid's frequencies: `loop_curve`)."""
        curves = [
            self.loop_curve(at, label, k, role, with_margins, points) for at, k, label, role in self.shown(iteration)
        ]
        return [c for c in curves if c is not None]

    def step_response(
        self, iteration: int | None = None, condition: int = 0, span: float | None = None
    ) -> tuple[list[float], list[float], str] | None:
        """Closed-loop response to a unit step (`step_setup`) of one condition, for
        rational plants; None otherwise."""
        found = self.step(iteration, condition, span)
        return None if found is None else (found.t, found.y, found.name)

    def step(self, iteration: int | None = None, condition: int = 0, span: float | None = None):
        """The `StepResponse` of one condition at an iteration (None: neither a rational loop nor one
        with delays, `network_step`)."""
        problem = self.problem
        if condition >= len(problem.conditions):
            return None
        return network_step(
            problem.conditions[condition].network, self.parameters(iteration, condition), self.step_setup, span
        )

    def step_loop(self, condition: int = 0):
        """The current design's closed loop (state space) of one condition, or None."""
        problem = self.problem
        if condition >= len(problem.conditions) or not problem.conditions[condition].network.rational:
            return None
        return realized(problem.conditions[condition].network, self.parameters(None, condition))

    def step_signals(self, condition: int = 0) -> tuple[tuple[str, ...], tuple[str, ...]] | None:
        """The inputs and the signals the step plot chooses among (None: this condition has no step
        response: neither rational nor a continuous loop with delays or tables)."""
        ss = self.step_loop(condition)
        if ss is not None:
            return ss.inputs, ss.outputs
        if condition >= len(self.problem.conditions):
            return None
        network = self.problem.conditions[condition].network
        stepped = has_delays(network) or has_tables(network)
        return (network.inputs, network.signals) if stepped and network.inputs else None

    def step_plot(self) -> tuple[str, list[tuple[list[float], list[float], str, str]], Any]:
        """What the step plot draws (`shown`), each response simulated once: what is
        plotted, (t, y, label, role) per trace over the current design's horizon, and
        the current design's `StepMeasures` (first plotted condition; None without one)."""
        name, traces, marks = "", [], None
        for at, k, label, role in self.shown():
            ss = self.step_loop(k)
            response = self.step(at, k, horizon(ss) if ss is not None else None)
            if response is not None:
                name = response.name
                traces.append((response.t, response.y, label, role))
                if at is None and not traces[:-1]:
                    marks = response.measures
        return name, traces, marks

    def trajectories(self) -> dict | None:
        """The presenter's trajectories of the current iteration (iteration 0's before any)."""
        records = self.records or tuple(r for r in [self.initial] if r is not None)
        return tolerant(lambda: self.presenter.trajectories(records), lambda: None)

    def convergence(self) -> tuple[str, list[int], list[float]]:
        """The convergence curve as the presenter measures it, from iteration 0 (the
        presenter's record of the start) on: label, iterations, values."""
        label, points = "", []
        for r in ((self.initial,) if self.initial is not None else ()) + self.records:
            label, value = tolerant(lambda: self.presenter.convergence(r), lambda: (label, None))
            if value is not None and math.isfinite(value):
                points.append((r.iteration, float(value)))
        return label, [p[0] for p in points], [p[1] for p in points]

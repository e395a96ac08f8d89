"""A fifth algorithm, kept in the tests: compass search on the tableau.

It touches no file of loopcraft: it is a plug-in package installed beside it
(tests/plugins/pyproject.toml declares its entry point), and the CLI, the
workbench and the sweeps, Dask workers included, find it there and show it
through its presenter alone.  Each iteration probes every free parameter up and
down by a factor (1 + step) and keeps the best probe when it lowers the
merit (unmet targets first, then the summed relative shortfall); with no
better probe the step is halved, and below `min_step` the search has
converged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from engine.design.measure_kinds import TargetUse, names
from engine.design.problem import Problem
from engine.design.tableau import tableau
from engine.errors import EngineError
from engine.stepping.memory_fields import Fields
from engine.stepping.presenter import Presenter
from engine.stepping.protocol import BoundStepper, State, Status, StepRecord
from engine.stepping.registry import Registration


@dataclass(frozen=True)
class CompassSettings:
    step: float = 0.5
    min_step: float = 0.01


@dataclass(frozen=True)
class CompassMemory:
    """The probe factor to try next."""

    step: float

    def to_json(self) -> dict:
        return {"step": self.step}

    @classmethod
    def from_json(cls, data: Any) -> CompassMemory:
        return cls(Fields(data, "compass memory").number("step"))


def merit(rows) -> float:
    """Unmet targets, then the summed relative shortfall (smaller is better)."""
    shortfall = sum(
        max(0.0, (r.desired - r.value) if r.at_least else (r.value - r.desired)) / max(abs(r.desired), 1e-9)
        for r in rows
        if r.desired is not None and np.isfinite(r.value)
    )
    return sum(not r.satisfied for r in rows) + shortfall / (1.0 + shortfall)


class Compass(BoundStepper):
    name = "compass"
    memory_type = CompassMemory
    settings: CompassSettings

    def init(self) -> State:
        return State(0, tuple(self.problem.vector()), Status.RUNNING, CompassMemory(self.settings.step))

    def _evaluate(self, x: np.ndarray) -> tuple[float, tuple]:
        try:
            rows = tuple(tableau(self.problem.with_vector(x)))
        except EngineError:
            return float("inf"), ()
        return merit(rows), rows

    def step(self, state: State) -> tuple[State, StepRecord]:
        x = np.array(state.x)
        best, rows = self._evaluate(x)
        step, probes, chosen = state.memory.step, 0, x
        for k in range(x.size):
            for factor in (1 + step, 1 / (1 + step)):
                trial = x.copy()
                trial[k] *= factor
                value, trial_rows = self._evaluate(trial)
                probes += 1
                if value < best:
                    best, rows, chosen = value, trial_rows, trial
        moved = chosen is not x
        step = step if moved else step / 2
        status = Status.CONVERGED if step < self.settings.min_step else Status.RUNNING
        record = StepRecord(
            state.iteration + 1,
            status,
            self.problem.named(chosen),
            rows,
            objective=best,
            step_size=step,
            counters={"probes": probes},
            extra={"moved": moved},
        )
        return State(state.iteration + 1, tuple(chosen), status, CompassMemory(step)), record


class CompassPresenter(Presenter):
    """Its own convergence label, line under the tableau and report."""

    def convergence(self, record: StepRecord) -> tuple[str, float | None]:
        return "compass merit", record.objective

    def status_lines(self, record: StepRecord) -> list[str]:
        moved = "moved" if record.extra.get("moved") else "stayed (step halved)"
        return [f"compass step {record.step_size:.4g}, {record.counters['probes']} probes, {moved}"]

    def report(self, record: StepRecord, problem: Problem) -> str:
        lines = [f"COMPASS SEARCH ITERATION {record.iteration}  MERIT {record.objective:.6g}"]
        lines += [f"  {r.name:<6} {r.value:12.6g}  {'MET' if r.satisfied else 'UNMET'}" for r in record.measures]
        return "\n".join(lines)


REGISTRATION = Registration(
    name="compass",
    bind=Compass.bind,
    settings=CompassSettings,
    memory_type=CompassMemory,
    summary="compass search on the tableau (tests only)",
    presenter=CompassPresenter(),
    targets=TargetUse(measures=names(), refusal="is not a measure of the tableau"),
)

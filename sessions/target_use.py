"""Which algorithm uses which target: the Targets tab's 'used by' column and
the list shown when another algorithm is chosen, read from what each installed
algorithm's registration declares (`TargetUse`, engine.stepping.registry); and the
targets an algorithm does not read, judged beside its run (`JudgedAside`): the algorithm
runs on the targets it reads, the others are evaluated at every iteration's design and shown
in its tableau, taking no part in its ranking or its convergence, and its stop names them
with their verdicts."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from engine.design.measure_kinds import MEASURE_KINDS
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.stepping.protocol import MeasureRow, State, Stepper, StepRecord
from engine.stepping.registry import Registration, lookup, registrations


def used_by(measure: str) -> str:
    """The algorithms whose targets may name ``measure`` ('cip, slp')."""
    found = [name for name, r in registrations().items() if r.targets.accepts(measure)]
    return ", ".join(found) if found else "none"


def _known(algorithm: str) -> Registration | None:
    try:
        return lookup(algorithm)
    except EngineError:
        return None


def target_note(measure: str, algorithm: str) -> str:
    """'' when ``algorithm`` uses the measure (or is not one installed), else a short
    note: 'not cip (slp)', 'ignored by qcg'."""
    registration = _known(algorithm)
    if registration is None or measure not in MEASURE_KINDS:
        return ""
    if not registration.targets.reads:
        return f"ignored by {algorithm}"
    if registration.targets.accepts(measure):
        return ""
    return f"not {algorithm} ({used_by(measure)})"


def unusable_targets(measures: Sequence[str], algorithm: str) -> list[str]:
    """One line per target ``algorithm`` will refuse or ignore, saying which and why."""
    registration = _known(algorithm)
    if registration is None or not measures:
        return []
    use = registration.targets
    if not use.reads:
        reason = use.refusal.removeprefix(f"is not read by {algorithm} ")
        return [f"{algorithm} {reason}: the {len(measures)} target(s) are kept but not used"]
    return [
        f"{m}: judged only: {algorithm} does not read it (it {use.why_not(m)}); used by {used_by(m)}"
        for m in measures
        if m in MEASURE_KINDS and not use.accepts(m)
    ]


def read_targets(registration: Registration, problem: Problem) -> tuple[Problem, Problem | None]:
    """(the problem with the targets the algorithm reads, the problem with those it does not
    or None): an algorithm that reads targets but not all of them runs on the ones it reads."""
    use = registration.targets
    refused = [t for t in problem.targets if not use.accepts_target(t)]
    if not use.reads or not refused or len(refused) == len(problem.targets):
        return problem, None
    kept = tuple(t for t in problem.targets if use.accepts_target(t))
    return dataclasses.replace(problem, targets=kept), dataclasses.replace(problem, targets=tuple(refused))


class JudgedAside:
    """A bound stepper run on the targets it reads, with the rows of the others (``aside``, a
    problem holding only them) judged at every record's design and added to its tableau; a
    finished record's reason names them with their verdicts."""

    def __init__(self, stepper: Stepper, aside: Problem):
        self._stepper, self._aside = stepper, aside

    def __getattr__(self, name: str) -> object:
        return getattr(self._stepper, name)

    def init(self) -> State:
        return self._stepper.init()

    def step(self, state: State) -> tuple[State, StepRecord]:
        state, record = self._stepper.step(state)
        return state, self._with_judged(record)

    def initial_record(self, state: State) -> StepRecord | None:
        record = self._stepper.initial_record(state)
        return None if record is None else self._with_judged(record)

    def _with_judged(self, record: StepRecord) -> StepRecord:
        rows = self.judged_rows(dict(record.parameters))
        reason = record.reason
        if record.status.finished and rows:
            verdicts = ", ".join(f"{r.name} {r.value:.6g} {'met' if r.satisfied else 'NOT met'}" for r in rows)
            reason = f"{reason}; judged only ({self._stepper.name} does not read them): {verdicts}"
        return dataclasses.replace(record, measures=tuple(record.measures) + rows, reason=reason)

    def judged_rows(self, values: dict) -> tuple[MeasureRow, ...]:
        """The aside targets' rows at the design ``values`` (slp's rows: every measure)."""
        from engine.slp.measures import evaluate, measure_specs

        problem = self._aside
        specs = measure_specs(problem, require_stable=False)
        x = problem.vector_from(values)
        found, frequencies = evaluate(problem, x, specs)
        how = f"judged only: {self._stepper.name} does not read it"
        return tuple(
            MeasureRow(
                spec.name,
                spec.kind,
                problem.conditions[spec.condition].name,
                float(v),
                spec.required,
                bool(spec.met(v)),
                None if np.isnan(f) else float(f),
                spec.at_least,
                how,
            )
            for spec, v, f in zip(specs, found, frequencies)
        )

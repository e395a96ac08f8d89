"""How an algorithm's records are shown: the one place that reads a record's
algorithm-specific `extra` (docs/architecture.md, "Presenters").

A `Presenter` is plain text and data, no widgets: the workbench, the CLI's
`report` and the sweeps all ask the algorithm's presenter (it travels with
the registration) and never branch on the algorithm's name.  The base class
is what an algorithm without its own presenter gets: the generic tableau,
the cost (or the count of unmet targets) as its convergence value, the
loop plots.  The presenters live next to their algorithms
(`engine/<name>/present.py`): they know the record layouts their algorithm
writes, and the engine stays free of any UI.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TypeVar

from engine.design.problem import Problem
from engine.design.tableau import tableau
from engine.errors import EngineError
from engine.stepping.protocol import MeasureRow, State, Status, Stepper, StepRecord

LOOP_PLOTS = frozenset({"nyquist", "bode", "nichols", "convergence", "step", "closed_loop", "poles", "locus"})
# what reading a record's free-form `extra` raises when a session file was edited by hand
MALFORMED_EXTRA = (KeyError, TypeError, ValueError, IndexError, AttributeError)
HEADLINE_COUNTERS = ("trials", "KNT", "KOUNT", "evaluations")
T = TypeVar("T")


def tolerant(call: Callable[[], T], fallback: Callable[[], T]) -> T:
    """``call()``, or ``fallback()`` when a record's `extra` is not what its presenter
    wrote (a session edited by hand): the generic presentation, never a traceback."""
    try:
        return call()
    except MALFORMED_EXTRA:
        return fallback()


def number(value: object, digits: int = 6) -> str:
    """A number as the tableaux and the report print it ('-' for a missing crossing, '' for none;
    a list or tuple, one value per condition, joined by ' / ')."""
    if value is None:
        return ""
    if isinstance(value, (list, tuple)):
        return " / ".join(number(v, digits) for v in value)
    if isinstance(value, float) and math.isnan(value):
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


def tableau_text(rows: Sequence[MeasureRow], unit: str = "rad/s") -> str:
    """The report-000 style table: number, name, kind, condition, value, frequency (in
    ``unit``, 'hz' or 'rad/s'; the rows hold rad/s), desired value, met, method; the
    columns as wide as their widest entry."""
    scale = 1 / (2 * math.pi) if unit == "hz" else 1.0
    head = ("no.", "name", "kind", "condition", "value", f"freq {unit}", "desired", "met", "method")
    body = [
        (
            str(n),
            r.name,
            r.kind,
            r.condition,
            f"{r.value:.6g}",
            "" if r.frequency is None else f"{r.frequency * scale:.6g}",
            "" if r.desired is None else f"{r.desired:.6g}",
            "yes" if r.satisfied else "NO",
            r.method or "",
        )
        for n, r in enumerate(rows, start=1)
    ]
    widths = [max(len(line[k]) for line in [head, *body]) for k in range(len(head))]
    right = {0, 4, 5, 6}
    return "\n".join(
        "  ".join(
            cell.rjust(w) if k in right else cell.ljust(w) for k, (cell, w) in enumerate(zip(line, widths))
        ).rstrip()
        for line in [head, *body]
    )


def parameters_line(record: StepRecord, count: int = 8) -> str:
    """The first parameters of a record on one line (a list per condition as a/b/c)."""

    def text(value: float | list[float]) -> str:
        return "/".join(number(v, 3) for v in value) if isinstance(value, list) else number(value, 5)

    return "  ".join(f"{k}={text(v)}" for k, v in list(record.parameters.items())[:count])


class Presenter:
    """The generic presentation; an algorithm subclasses what it shows differently."""

    plots: frozenset[str] = LOOP_PLOTS  # which of the workbench's plots apply
    maximize: bool = False  # sweeps rank runs by `ranking`, larger better when True

    def initial_record(self, stepper: Stepper, state: State) -> StepRecord | None:
        """Iteration 0 as a record: the tableau at the start (None when it cannot be computed)."""
        problem = stepper.problem
        try:
            rows = tuple(tableau(problem))
        except EngineError:
            return None
        return StepRecord(0, Status.RUNNING, problem.named(), rows)

    def convergence(self, record: StepRecord) -> tuple[str, float | None]:
        """What the convergence plot shows of a record: (label, value)."""
        if record.objective is not None:
            return "cost", record.objective
        return "unmet targets", float(sum(not m.satisfied for m in record.measures))

    def ranking(self, record: StepRecord) -> float | None:
        """The value sweeps rank a finished run by (see `maximize`)."""
        return record.objective

    def summary(self, record: StepRecord) -> dict[str, object]:
        """Algorithm-specific fields of a sweep run's summary (JSON data)."""
        return {}

    def status_lines(self, record: StepRecord) -> list[str]:
        """The lines under the workbench's tableau for a record."""
        return [self.headline(record), parameters_line(record)]

    def headline(self, record: StepRecord) -> str:
        """Step size, objective and the iteration's counters, on one line."""
        parts = [f"step {number(record.step_size, 4)}"] if record.step_size is not None else []
        if record.objective is not None:
            parts.append(f"objective {number(record.objective, 7)}")
        parts += [f"{k} {v}" for k, v in record.counters.items() if k in HEADLINE_COUNTERS]
        return "  ".join(parts)

    def report(self, record: StepRecord, problem: Problem) -> str:
        """`loopcraft report`'s text for a record (iteration 0 included)."""
        return tableau_text(record.measures, problem.grid.unit)

    def trajectories(self, records: Sequence[StepRecord]) -> dict[str, object] | None:
        """Time trajectories of the latest record, for algorithms that produce them:
        {"t", "x", "u"} and, when the first record has it, "open_loop"; else None."""
        return None

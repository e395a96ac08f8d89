"""What a design's numbers do not say by themselves: free parameters sitting at
(or within a hair of) a bound of their box, and a compensator whose high-frequency
gain is far above its gain at the crossover (it amplifies sensor noise).

An optimizer that "converges" with a time constant at its lower bound found the
box, not a design (slp drove a lead's pole to 1e4 rad/s and a high-frequency gain
near 1.35e5, and a gain to its lower bound); the CLI's `run` and `report`, the
workbench's status and the sweep's optima list these notes beside the verdict.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from engine.design.constraints import binding
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.margins.search import margins
from engine.model.blocks import ExpressionTransfer
from engine.stepping.protocol import MeasureRow, Status

HOLDING = 0.02  # a met requirement this close (relative) to its bound holds a stalled run back (slp's LP keeps 1 %)
STALLED = (Status.NO_IMPROVEMENT, Status.STEP_BELOW_MINIMUM, Status.INFEASIBLE, Status.ITERATION_LIMIT)
POLISH = (
    "every desired value reached: raise one to polish further "
    "(Targets tab: 3, then e on a target, e.g. a band '55 / 45'; in the JSON, a band's desired)"
)

AT_BOUND = 1e-6  # relative distance to a bound within which a parameter is "at" it


def at_bounds(problem: Problem, values: dict) -> list[str]:
    """'T2 at its lower bound 0.0001' for every free parameter (each condition's value of a
    per-condition one) at or within `AT_BOUND` of a finite bound."""
    notes = []
    for p in problem.parameters:
        if not p.free:
            continue
        value = values.get(p.name, p.value)
        for k, v in enumerate(value if isinstance(value, (list, tuple)) else [value]):
            where = f"[{problem.conditions[k].name}]" if isinstance(value, (list, tuple)) else ""
            for side, bound in (("lower", p.lower()), ("upper", p.upper())):
                if math.isfinite(bound) and abs(float(v) - bound) <= AT_BOUND * max(abs(bound), 1e-12):
                    notes.append(f"{p.name}{where} at its {side} bound {bound:.6g}")
    return notes


def noise_notes(problem: Problem, values: dict) -> list[str]:
    """For each condition's tunable blocks (expressions that read parameters): their product's
    gain at high frequency against its gain at the loop's gain crossover, flagged above the
    problem's ``noise_factor`` (noise amplification; the session's problem.noise_factor)."""
    factor = problem.noise_factor
    notes = []
    x = problem.vector_from(values)
    for c, condition in enumerate(problem.conditions):
        params = problem.condition_values(c, x)
        blocks = [e.transfer for e in condition.network.entries if _tunable(e.transfer)]
        if not blocks:
            continue
        try:
            wc = margins(
                loop_model(condition.network, condition.break_at, problem.grid.omega, params)
            ).crossover_frequency
            if wc is None:
                continue
            high, low = 1.0, 1.0
            with np.errstate(all="ignore"):  # extreme values: judged below, never warned about
                for transfer in blocks:
                    rational = transfer.rational(params)
                    high *= _high_frequency_gain(rational.num, rational.den)
                    low *= abs(np.polyval(rational.num, 1j * wc) / np.polyval(rational.den, 1j * wc))
                ratio = high / low if low > 0 else math.nan
        except (EngineError, ValueError, ZeroDivisionError, FloatingPointError):
            continue
        if math.isfinite(ratio) and ratio > factor:
            notes.append(
                f"{condition.name}: the compensator's high-frequency gain is {ratio:.3g} times its gain at "
                f"the crossover {wc:.4g} rad/s (above {factor:g}: it amplifies sensor noise)"
            )
    return notes


def design_notes(problem: Problem, values: dict) -> list[str]:
    """Every note on a design (`at_bounds`, `noise_notes`)."""
    return at_bounds(problem, values) + noise_notes(problem, values)


def _tunable(transfer: object) -> bool:
    return isinstance(transfer, ExpressionTransfer) and bool(transfer.parameters)


def _high_frequency_gain(num: np.ndarray, den: np.ndarray) -> float:
    """|K(j omega)| as omega -> inf of a proper ratio (inf for an improper one)."""
    num, den = np.trim_zeros(np.asarray(num, dtype=float), "f"), np.trim_zeros(np.asarray(den, dtype=float), "f")
    if num.size < den.size:
        return 0.0
    if num.size > den.size:
        return math.inf
    return abs(num[0] / den[0])


def stop_notes(problem: Problem, status: Status, values: dict, rows: Sequence[MeasureRow]) -> list[str]:
    """Why a run stopped where it did, in words and data, beside the algorithm's own reason:
    every requirement met and every desired value reached (what to do to polish further); or,
    for a run that found no better step or ran out of iterations, the constraints that bind
    and the parameters held at a bound at its last design, and the requirements unmet."""
    if not status.finished or status is Status.FAILED:
        return []
    unmet = [row for row in rows if not row.satisfied]
    if not unmet and status is Status.CONVERGED and all(_reached(row) for row in rows):
        return [POLISH]
    if status not in STALLED:
        return []
    notes = binding(problem, problem.vector_from(values)) + at_bounds(problem, values)
    notes += [f"holds: {_row_text(row)} at its requirement {row.desired:.6g}" for row in rows if _holding(row)]
    notes += [f"unmet: {_unmet_text(row)}" for row in unmet]
    return notes


def _holding(row: MeasureRow) -> bool:
    """A met requirement within `HOLDING` of its bound: one that holds the design back."""
    if not row.satisfied or row.desired is None or not math.isfinite(row.value) or not math.isfinite(row.desired):
        return False
    return abs(row.value - row.desired) <= HOLDING * max(abs(row.desired), 1e-9)


def _row_text(row: MeasureRow) -> str:
    return f"{row.name} ({row.kind}, {row.condition}) {row.value:.6g}"


def _reached(row: MeasureRow) -> bool:
    if row.desired is None:
        return True
    if math.isnan(row.value):
        return False
    return row.value >= row.desired if row.at_least else row.value <= row.desired


def _unmet_text(row: MeasureRow) -> str:
    return f"{_row_text(row)} {'<' if row.at_least else '>'} {row.desired:.6g}"

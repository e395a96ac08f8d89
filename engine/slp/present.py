"""How `slp` records are shown.  The tableau of a record as COEBRA's engineer reads it (report 003,
chapter 2): major and minor iteration, step size P, relaxation STEP, the
met-measure counter and figure of merit, then every measure with its
requirement, desired value, how its partials were computed, and its dual."""

from __future__ import annotations

import math

from engine.design.problem import Problem
from engine.stepping.presenter import Presenter, number
from engine.stepping.protocol import State, Stepper, StepRecord


def _number(value: float | None, width: int, digits: int = 6) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return f"{'-':>{width}}"
    return f"{value:>{width}.{digits}g}"


def slp_report_text(record: StepRecord) -> str:
    """Header lines and the measure table of one record (iteration 0: the start)."""
    e = record.extra
    lines = [
        f"ITERATION {record.iteration}   STATUS {record.status.value}"
        + (f" ({record.reason})" if record.reason else "")
    ]
    if "major" in e:
        lines.append(
            f"MAJOR {e['major']}  MINOR {e['minor']}  P {e['P']:.4g}  STEP {e['STEP']:.2f}  "
            f"LP {e['lp_status']}  trial {'accepted' if e['accepted'] else 'rejected'}"
        )
    lines.append(
        f"COUNTER {e.get('counter')}  FIGURE OF MERIT {e.get('figure_of_merit', float('nan')):.6g}"
        + (f"  (best {e['best_counter']}, {e['best_figure_of_merit']:.6g})" if "best_counter" in e else "")
    )
    lines.append("X= " + "  ".join(f"{k}={_values(v)}" for k, v in record.parameters.items()))
    desired = e.get("desired") or [None] * len(record.measures)
    partials, duals = e.get("partials", {}), e.get("duals", {})
    lines += [
        "",
        f"{'no.':>3} {'name':<6}{'condition':<12}{'value':>12}{'freq':>10}{'required':>10}"
        f"{'desired':>10} {'met':<4}{'partials':<18}{'dual':>10}",
    ]
    for k, (m, d) in enumerate(zip(record.measures, desired), start=1):
        key = f"{m.name}@{m.condition}"
        lines.append(
            f"{k:>3} {m.name:<6}{m.condition[:11]:<12}{_number(m.value, 12)}{_number(m.frequency, 10, 4)}"
            f"{_number(m.desired, 10, 4)}{_number(d, 10, 4)} {'yes' if m.satisfied else 'NO':<4}"
            f"{partials.get(key, ''):<18}{_number(duals.get(key), 10, 3)}"
        )
    notes = [f"{m.name}@{m.condition}: {m.method}" for m in record.measures if m.method]
    return "\n".join(lines + ([""] + notes if notes else []))


def _values(value) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(f"{v:.5g}" for v in value) + "]"
    return f"{value:.5g}"


class SlpPresenter(Presenter):
    """COEBRA's tableau; the minor loop's trial under the workbench's tableau."""

    maximize = True

    def initial_record(self, stepper: Stepper, state: State) -> StepRecord:
        return stepper.initial_record(state)  # its own stepper's, which knows the record's layout

    def status_lines(self, record: StepRecord) -> list[str]:
        e = record.extra
        lines = [self.headline(record)]
        if "major" in e:
            lines.append(
                f"major {e['major']} minor {e['minor']}  P {number(e['P'], 3)}  STEP {e['STEP']:.1f}  "
                f"{'accepted' if e['accepted'] else 'rejected'}  counter {e['counter']}"
            )
        return lines + super().status_lines(record)[1:]

    def report(self, record: StepRecord, problem: Problem) -> str:
        return slp_report_text(record)

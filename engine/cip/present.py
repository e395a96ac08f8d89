"""How `cip` records are shown: report 000's printout (listing OTPT1 and
MULOUT) of one record (the relative-stability and attenuated-frequency
sections, the direction split into numerator (X) and denominator (Y)
partials, every compensator factored and multiplied out, and the best
compensator so far), the workbench's lines under the tableau, and the
smallest stability margin as the convergence and ranking value."""

from __future__ import annotations

import math

from engine.cip.direction import REPORT
from engine.cip.requirements import KIND
from engine.design.problem import Problem
from engine.stepping.presenter import Presenter
from engine.stepping.protocol import State, Stepper, StepRecord

HZ = 2 * math.pi


def cip_report_text(record: StepRecord) -> str:
    """The record in the listing's layout (frequencies in Hz)."""
    lines = [f"{'ITERATION NO.':>40} {record.iteration:4d}"]
    if record.step_size is not None:
        lines.append(f"{'PRESENT STEP SIZE =':>40} {record.step_size:10.7f}")
    sections = (
        ("RELATIVE STABILITY INFORMATION", lambda k: k != "A"),
        ("ATTENUATED FREQUENCY INFORMATION", lambda k: k == "A"),
    )
    for title, wanted in sections:
        rows = [(n, r) for n, r in enumerate(record.measures, start=1) if wanted(KIND.get(r.kind, "?"))]
        if rows:
            lines += ["", f"{title:>58}", ""]
            lines += [_margin_line(n, r) for n, r in rows]
    methods = sorted({r.method for r in record.measures if getattr(r, "method", None)})
    if methods:
        lines += ["", f"  MARGINS DETECTED: {', '.join(methods)}"]
    lines += _partials(record.extra.get("partials"))
    direction = record.extra.get("direction", "")
    if direction and direction != REPORT:  # beyond the listing: say which
        lines.append(f"  DIRECTION: {direction.upper()} (NOT THE REPORT'S)")
    for comp in record.extra.get("compensators", []):
        lines += _compensator(comp)
    best = record.extra.get("best")
    if best:
        lines += [
            "",
            f"  BEST COMPENSATORS WITH RESPECT TO STABILITY OCCURRED ON STEP {best['iteration']}; "
            f"SMALLEST STABILITY MARGIN = {_fmt(best['smallest_stability_margin'])}",
        ]
    unmet = record.extra.get("unmet")
    if unmet is not None:
        lines.append(f"  UNMET REQUIREMENTS: {unmet} (at the start: {record.extra.get('unmet_start')})")
    if record.status.finished:
        lines.append(f"  ***** TERMINATION REASON - {record.status.value.upper()}: {record.reason} *****")
    return "\n".join(lines)


CLASSICAL = {"gain_margin_db": ("GAIN MARGIN", "DB"), "phase_margin_deg": ("PHASE MARGIN", "DEG")}


def _margin_line(n: int, r) -> str:
    """The listing's line; a classical margin (dB, deg) says so instead of MARGIN RADIUS; one read
    at another loop break than the condition's (row 2@u_att) names it."""
    flag = "" if r.satisfied else "  ACTIVE"
    flag += f"   AT BREAK {r.name.partition('@')[2]}" if "@" in r.name else ""
    label, unit = CLASSICAL.get(r.kind, ("MARGIN RADIUS", ""))
    unit = f" {unit}" if unit else ""
    return (
        f"  {label} NO. {n:3d} = {r.value:10.5f}{unit}   FREQUENCY = {r.frequency / HZ:10.5f} HZ   "
        f"DESIRED MARGIN = {r.desired:10.5f}{unit}   MARGIN TYPE = {KIND.get(r.kind, '?')}{flag}"
    )


def _partials(split: dict | None) -> list[str]:
    if not split:
        return []
    out = [""]
    for role, title in (
        ("numerator", "PARTIALS WITH RESPECT TO X"),
        ("denominator", "PARTIALS WITH RESPECT TO Y"),
        ("other", "PARTIALS WITH RESPECT TO OTHER PARAMETERS"),
    ):
        values = split.get(role, {})
        if values:
            out.append(f"  {title}:")
            items = [f"{name}={value:10.3e}" for name, value in values.items()]
            out += ["    " + "  ".join(items[i : i + 4]) for i in range(0, len(items), 4)]
    return out


def _compensator(comp: dict) -> list[str]:
    out = ["", f"{'CHANNEL ' + comp['group'] + ' COMPENSATORS':>50}"]
    for f in comp["factors"]:
        out.append(f"    {f['block']:<14} NUMERATOR   {_coefficients(f['numerator'])}")
        out.append(f"    {'':<14} DENOMINATOR {_coefficients(f['denominator'])}")
    out.append(f"    {'multiplied out':<14} NUMERATOR   {_coefficients(comp['numerator'], 'e')}")
    out.append(f"    {'':<14} DENOMINATOR {_coefficients(comp['denominator'], 'e')}")
    return out


def _coefficients(values: list, style: str = "f") -> str:
    return " ".join(f"{v:12.5e}" if style == "e" else f"{v:11.5f}" for v in values)


def _fmt(value) -> str:
    return "n/a" if value is None else f"{value:.5f}"


def compensator_lines(record: StepRecord, count: int = 2) -> list[str]:
    """The first compensators' multiplied-out numerator and denominator, two lines each."""
    lines = []
    for comp in record.extra.get("compensators", [])[:count]:
        lines.append(f"{comp['group']}: num {' '.join(f'{c:.4g}' for c in comp['numerator'])}")
        lines.append(f"{'':{len(comp['group'])}}  den {' '.join(f'{c:.4g}' for c in comp['denominator'])}")
    return lines


class CipPresenter(Presenter):
    """Report 000's listing; runs converge on (and are ranked by) the smallest stability margin."""

    maximize = True

    def initial_record(self, stepper: Stepper, state: State) -> StepRecord:
        return stepper.initial_record(state)  # its own stepper's, which knows the record's layout

    def convergence(self, record: StepRecord) -> tuple[str, float | None]:
        return "smallest stability margin", record.extra.get("smallest_stability_margin")

    def ranking(self, record: StepRecord) -> float | None:
        return record.extra.get("smallest_stability_margin")

    def status_lines(self, record: StepRecord) -> list[str]:
        return [self.headline(record)] + (compensator_lines(record) or super().status_lines(record)[1:])

    def report(self, record: StepRecord, problem: Problem) -> str:
        return cip_report_text(record)

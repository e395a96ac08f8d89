"""Report 000's printout (listing OTPT1 and MULOUT) of one `cip` record:
the relative-stability and attenuated-frequency sections, the direction
split into numerator (X) and denominator (Y) partials, every compensator
factored and multiplied out, and the best compensator so far."""

from __future__ import annotations

import math

from engine.algorithm import StepRecord
from engine.cip.constraints import KIND

HZ = 2 * math.pi


def cip_report_text(record: StepRecord) -> str:
    """The record in the listing's layout (frequencies in Hz)."""
    lines = [f"{'ITERATION NO.':>40} {record.iteration:4d}"]
    if record.step_size is not None:
        lines.append(f"{'PRESENT STEP SIZE =':>40} {record.step_size:10.7f}")
    sections = (("RELATIVE STABILITY INFORMATION", lambda k: k != "A"),
                ("ATTENUATED FREQUENCY INFORMATION", lambda k: k == "A"))
    for title, wanted in sections:
        rows = [(n, r) for n, r in enumerate(record.measures, start=1) if wanted(KIND.get(r.kind, "?"))]
        if rows:
            lines += ["", f"{title:>58}", ""]
            lines += [_margin_line(n, r) for n, r in rows]
    methods = sorted({r.method for r in record.measures if getattr(r, "method", None)})
    if methods:
        lines += ["", f"  MARGINS DETECTED: {', '.join(methods)}"]
    lines += _partials(record.extra.get("partials"))
    for comp in record.extra.get("compensators", []):
        lines += _compensator(comp)
    best = record.extra.get("best")
    if best:
        lines += ["", f"  BEST COMPENSATORS WITH RESPECT TO STABILITY OCCURRED ON STEP {best['iteration']}; "
                      f"SMALLEST STABILITY MARGIN = {_fmt(best['smallest_stability_margin'])}"]
    unmet = record.extra.get("unmet")
    if unmet is not None:
        lines.append(f"  UNMET REQUIREMENTS: {unmet} (at the start: {record.extra.get('unmet_start')})")
    if record.status.finished:
        lines.append(f"  ***** TERMINATION REASON - {record.status.value.upper()}: {record.reason} *****")
    return "\n".join(lines)


def _margin_line(n: int, r) -> str:
    flag = "" if r.satisfied else "  ACTIVE"
    return (f"  MARGIN RADIUS NO. {n:3d} = {r.value:10.5f}   FREQUENCY = {r.frequency / HZ:10.5f} HZ   "
            f"DESIRED MARGIN = {r.target:10.5f}   MARGIN TYPE = {KIND.get(r.kind, '?')}{flag}")


def _partials(split: dict | None) -> list[str]:
    if not split:
        return []
    out = [""]
    for role, title in (("numerator", "PARTIALS WITH RESPECT TO X"), ("denominator", "PARTIALS WITH RESPECT TO Y"),
                        ("other", "PARTIALS WITH RESPECT TO OTHER PARAMETERS")):
        values = split.get(role, {})
        if values:
            out.append(f"  {title}:")
            items = [f"{name}={value:10.3e}" for name, value in values.items()]
            out += ["    " + "  ".join(items[i:i + 4]) for i in range(0, len(items), 4)]
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

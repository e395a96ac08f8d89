"""The Run tab's tableau as one rich text: far cheaper to draw than a table
widget while a run goes.  Values changed since the previous iteration are
bold, unmet rows are marked NO in red, the margins' method closes it; and the
lines of the loops at every break of a condition that names several (`break_lines`)."""

from __future__ import annotations

import math
from collections.abc import Mapping

from rich.text import Text

from engine.design.measure_kinds import shorts
from engine.design.problem import Problem
from engine.multiloop.diagram_breaks import DiagramBreaks, diagram_breaks
from engine.stepping.presenter import number
from engine.stepping.protocol import MeasureRow

SHORT = shorts()


COMPACT_WIDTH = 58  # narrower: no name column, the conditions as headings (80x24 terminals)


def tableau_text(rows: list[MeasureRow], previous: list[MeasureRow], unit: str, width: int | None = None) -> Text:
    """The rows (frequencies in ``unit``), bold where they differ from ``previous``;
    narrower than COMPACT_WIDTH, without names and with each condition as a heading."""
    scale = 1 / (2 * math.pi) if unit == "hz" else 1.0
    before = {(r.name, r.kind, r.condition): r.value for r in previous}
    several = len({r.condition for r in rows}) > 1
    compact = width is not None and width < COMPACT_WIDTH
    column = several and not compact
    wide = min(max([8] + [len(r.name) for r in rows]), 18)  # names whole ('x1_normalized'), within reason
    text = Text(
        ("" if compact else f"{'no.':<{wide}} ")
        + (f"{'condition':<10} " if column else "")
        + f"{'kind':<6} {'value':>9} met {'target':>7} {'freq ' + unit:>10}\n",
        style="bold",
        no_wrap=True,
        overflow="crop",
    )
    heading = None
    for r in rows:
        if compact and several and r.condition != heading:
            heading = r.condition
            text.append(f"{r.condition}\n", style="underline")
        key = (r.name, r.kind, r.condition)
        changed = key in before and before[key] != r.value
        freq = "" if r.frequency is None else number(r.frequency * scale, 5)
        text.append(
            ("" if compact else f"{r.name[:wide]:<{wide}} ")
            + (f"{r.condition[:10]:<10} " if column else "")
            + f"{SHORT.get(r.kind, r.kind)[:6]:<6} "
        )
        text.append(f"{number(r.value, 5):>9}", style="bold" if changed else "")
        text.append(" yes " if r.satisfied else " NO  ", style="" if r.satisfied else "bold red")
        text.append(f"{number(r.desired, 4):>7} {freq:>10}\n")
    methods = sorted({r.method for r in rows if r.method})
    if methods:
        text.append(f"margins: {', '.join(methods)}\n", style="dim")
    return text


def break_lines(problem: Problem, condition: int, values: Mapping[str, float]) -> str:
    """The loops at every break of one condition, under the tableau (rows named as the targets'
    rows are: GM@u_att): loop at a time (broken there, every other loop closed) the gain margin
    and the phase margin nearest 0 (as the Bode legend gives them) and the disk margin (skew 0),
    each with its frequency; then the multi-loop disk margin at every break at once (certified bracket).  ''
    when the condition names one break."""
    c = problem.conditions[condition]
    if not c.several_breaks:
        return ""
    scale = 1 / (2 * math.pi) if problem.grid.unit == "hz" else 1.0
    found = diagram_breaks(c.network, c.every_break, problem.grid.omega, values)
    lines = [
        f"every break of {c.name}: loop at a time, the others closed (closed loop {found.verdict})",
        f"{'row':<12} {'value':>9} {'':<5} {'freq ' + problem.grid.unit:>10}",
    ]
    for b in found.loops:
        if b.margins is None:
            lines.append(f"{'@' + b.name:<12} cannot be analyzed: {b.failure}")
            continue
        gm = min(b.margins.listed("G"), key=lambda m: abs(m.gain_db), default=None)
        pm = min(b.margins.phase, key=lambda m: abs(m.phase_deg), default=None)
        disk = b.disk_margin
        rows = [
            ("GM", gm and (gm.gain_db, gm.frequency), "dB"),
            ("PM", pm and (pm.phase_deg, pm.frequency), "deg"),
            ("disk", disk and (disk.alpha, disk.frequency), "alpha"),
        ]
        for short, pair, unit in rows:
            value, w = (
                ("none", "") if pair is None else (f"{number(pair[0], 5):>9} {unit:<5}", number(pair[1] * scale, 5))
            )
            lines.append(f"{short + '@' + b.name:<12} {value:>15} {w:>10}".rstrip())
    return "\n".join(lines + [_together(found, scale)])


def _together(found: DiagramBreaks, scale: float) -> str:
    """The multi-loop disk margin's lines (row MDM, as its target's rows are named): alpha at its
    worst frequency, its status and certified bracket."""
    d = found.together
    if d is None:
        return f"multi-loop disk margin: not computed ({found.together_failure})"
    at = "inf" if d.frequency == math.inf else number(d.frequency * scale, 5)
    return (
        f"{'MDM':<12} {number(d.alpha, 5):>9} {'alpha':<5} {at:>10}\n"
        f"  multi-loop disk margin, every break at once: {d.status} [{number(d.alpha_lower, 6)}, "
        f"{number(d.alpha_upper, 6)}]"
    )

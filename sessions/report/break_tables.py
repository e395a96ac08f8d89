"""The report's loops at every break (issue 57): for each flight condition whose `breaks` name
more than its primary break, the loop-at-a-time margins at each break (the loop broken there,
every other loop closed) and the multi-loop disk margin at all of them at once, as
`engine.multiloop.diagram_breaks` finds them.  Blocks as `sessions.report.content`
describes them."""

from __future__ import annotations

import math
from typing import Any

from engine.design.problem import Condition
from engine.multiloop.diagram_breaks import BreakLoop, DiagramBreaks, diagram_breaks
from engine.multiloop.disk import MultiLoopDiskMargin
from engine.stepping.presenter import number
from sessions.store import Session

Block = tuple
HEADER = ("break", "gain margins (dB at {unit})", "phase margins (deg at {unit})", "crossover ({unit})", "disk margin")


def break_blocks(session: Session, named: dict[str, Any]) -> list[Block]:
    """A heading, then per condition with several breaks its per-break table and its multi-loop
    disk margin (nothing when no condition has several breaks)."""
    problem = session.problem
    scale = 2 * math.pi if problem.grid.unit == "hz" else 1.0
    blocks: list[Block] = []
    for k, c in enumerate(problem.conditions):
        if not c.several_breaks:
            continue
        values = problem.condition_values(k, named=named)
        found = diagram_breaks(c.network, c.every_break, problem.grid.omega, values)
        blocks.append(("h3", f"Condition {c.name}: every break"))
        blocks.append(_per_break(found, problem.grid.unit, scale))
        blocks.append(_together(c, found, problem.grid.unit, scale))
    if not blocks:
        return []
    intro = (
        "Loop at a time: at each break the loop is broken at that signal and every other loop stays "
        "closed (the grid-free margin search of one loop); the multi-loop disk margin perturbs every "
        "break at once (independent complex perturbations, skew 0), certified between two bounds."
    )
    return [("h2", "Loops at every break"), ("p", intro), *blocks]


def _per_break(found: DiagramBreaks, unit: str, scale: float) -> Block:
    rows = [[b.name, *_break_cells(b, found.verdict, scale)] for b in found.loops]
    return ("table", tuple(h.format(unit=unit) for h in HEADER), rows)


def _break_cells(b: BreakLoop, verdict: str, scale: float) -> list[str]:
    m = b.margins
    if m is None:
        return [f"cannot be analyzed: {b.failure}", "", "", ""]
    gains = "; ".join(f"{number(g.gain_db)} at {number(g.frequency / scale)}" for g in m.gain) or "none"
    phases = "; ".join(f"{number(p.phase_deg)} at {number(p.frequency / scale)}" for p in m.phase) or "none"
    wc = "none" if m.crossover_frequency is None else number(m.crossover_frequency / scale)
    d = b.disk_margin
    disk = "not computed" if d is None else f"alpha {number(d.alpha)} at {number(d.frequency / scale)}"
    if verdict != "stable":
        disk += f" (closed loop {verdict})"
    return [gains, phases, wc, disk]


def _together(c: Condition, found: DiagramBreaks, unit: str, scale: float) -> Block:
    if found.together is None:
        return ("p", f"Multi-loop disk margin at {', '.join(c.every_break)}: not computed ({found.together_failure}).")
    return ("table", ("multi-loop disk margin", ""), _together_rows(found.together, unit, scale))


def _together_rows(d: MultiLoopDiskMargin, unit: str, scale: float) -> list[list[str]]:
    at = "at infinity" if d.frequency == math.inf else f"{number(d.frequency / scale)} {unit}"
    return [
        ["alpha", number(d.alpha)],
        ["certified bracket", f"[{number(d.alpha_lower, 9)}, {number(d.alpha_upper, 9)}] ({d.status})"],
        ["gain (every break at once)", f"{number(d.gain_low_db)} .. {number(d.gain_high_db)} dB"],
        ["phase (every break at once)", f"+- {number(d.phase_deg)} deg"],
        ["worst frequency", at],
        ["how obtained", d.method],
        *[["note", n] for n in d.notes],
    ]

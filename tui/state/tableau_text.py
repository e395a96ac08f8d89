"""The Run tab's tableau as one rich text: far cheaper to draw than a table
widget while a run goes.  Values changed since the previous iteration are
bold, unmet rows are marked NO in red, the margins' method closes it."""

from __future__ import annotations

import math

from rich.text import Text

from engine.design.measure_kinds import shorts
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

"""What `y` copies to the clipboard (OSC 52, which works over SSH): a table's
selected row, the tableau, or the current compensator as an expression."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

from sessions.forms.transfers import format_sub_compensator, format_transfer, transfer_names
from tui.state.plant_rows import cascade_transfers


def row_text(cells: Sequence[object]) -> str:
    """A table row as tab-separated text (it pastes into a spreadsheet's columns)."""
    return "\t".join(str(c) for c in cells)


def with_values(text: str, values: Mapping[str, float]) -> str:
    """``text`` with every parameter name replaced by its value (exactly, as repr)."""

    def value(match: re.Match) -> str:
        name = match.group(0)
        v = values.get(name)
        return name if v is None or isinstance(v, list) else f"({float(v)!r})" if v < 0 else repr(float(v))

    return re.sub(r"\b[A-Za-z_][A-Za-z0-9_]*\b", value, text)


def design_text(problem_model, values: Mapping[str, float], condition: int = 0) -> str:
    """Every block of one condition that reads a parameter, as 'NAME = DEFINITION' with the
    current values in place (one line each); '' when no block reads one."""
    cond = problem_model.conditions[condition]
    x = cond.variable
    lines = []
    for name, transfer in _transfers(cond.plant):
        if transfer_names(transfer, x):
            lines.append(f"{name} = {with_values(format_transfer(transfer, x), values)}")
    if cond.plant.format == "channels":
        lines += [
            f"{ch.name}.{n + 1} = {with_values(format_sub_compensator(sub), values)}"
            for ch in cond.plant.channels
            for n, sub in enumerate(ch.compensators)
        ]
    return "\n".join(lines)


def _transfers(plant) -> list[tuple[str, object]]:
    if plant.format == "diagram":
        return [(b.name, b.transfer) for b in plant.blocks]
    if plant.format == "cascade":
        return [(n.upper(), t) for n, t in cascade_transfers(plant)]
    if plant.format == "channels":
        return [(f"{ch.name}.response", ch.response) for ch in plant.channels]
    return []

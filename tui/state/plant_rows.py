"""The rows of the Plant tab: one per block, junction, matrix entry, channel
or break point of every condition, each with the model path it shows.  A
state-space block is shown by its order, poles and zeros, read from the built
problem's block of the same name (its file is read once, when the session is)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from engine.model.blocks import StateSpaceTransfer
from sessions.forms.transfers import describe_state_space, describe_transfer, format_sub_compensator
from tui.state.edits import Ref

if TYPE_CHECKING:
    from collections.abc import Sequence

    from engine.design.constraints import ConstraintState
    from engine.design.problem import Problem

Cells = tuple[str, str, str, str, str, str]


def plant_rows(model, problem: Problem | None = None) -> list[tuple[Cells, Ref | None]]:
    """(condition, block, input, output, kind, definition) and the row's model path;
    ``problem`` (the engine's, built from ``model``) describes the state-space blocks."""
    rows: list[tuple[Cells, Ref | None]] = []
    for k, condition in enumerate(model.conditions):
        built = _state_spaces(problem, k, condition.name)
        in_z = condition.sample_time is not None
        rows += [((condition.name,) + cells, ref) for cells, ref in _condition_rows(condition, k, built, in_z)]
        if condition.sample_time is not None:  # a loop in z: its sample time, edited on its own row
            T = condition.sample_time
            every = f"every {T:g} s (Nyquist frequency pi/T = {math.pi / T:.6g} rad/s)"
            rows.append(((condition.name, "(sampled)", "", "", "in z", every), ("conditions", k, "sample_time")))
    return rows


def _state_spaces(problem: Problem | None, k: int, name: str) -> dict[str, StateSpaceTransfer]:
    """The state-space blocks of condition ``k`` of the built problem, by label (none when
    the problem is not given or is not of this model)."""
    if problem is None or k >= len(problem.conditions) or problem.conditions[k].name != name:
        return {}
    entries = problem.conditions[k].network.entries
    return {e.label: e.transfer for e in entries if isinstance(e.transfer, StateSpaceTransfer)}


def _condition_rows(
    condition, k: int, built: dict[str, StateSpaceTransfer], in_z: bool = False
) -> list[tuple[tuple[str, ...], Ref | None]]:
    plant, base, x = condition.plant, ("conditions", k, "plant"), condition.variable

    def describe(transfer, label: str) -> str:
        if transfer.kind == "state_space" and label in built:
            return describe_state_space(built[label], in_z)
        return describe_transfer(transfer, x)

    if plant.format == "diagram":
        rows = [
            (
                (
                    b.name,
                    " ".join(b.signals_in),
                    " ".join(b.signals_out),
                    b.transfer.kind,
                    describe(b.transfer, b.name),
                ),
                base + ("blocks", i),
            )
            for i, b in enumerate(plant.blocks)
        ]
        rows += [
            (
                (j.name, " ".join([f"+{s}" for s in j.plus] + [f"-{s}" for s in j.minus]), j.output, "junction", ""),
                base + ("junctions", i),
            )
            for i, j in enumerate(plant.junctions)
        ]
        rows.append((("(loop broken at)", condition.break_at, "", "", ""), ("conditions", k, "break_at")))
        return rows
    if plant.format == "channels":
        rows = []
        for i, ch in enumerate(plant.channels):
            rows.append(
                (
                    (
                        f"{ch.name}.response",
                        "e",
                        f"{ch.name}.theta",
                        ch.response.kind,
                        describe(ch.response, f"{ch.name}.response"),
                    ),
                    base + ("channels", i, "response"),
                )
            )
            for n, sub in enumerate(ch.compensators):
                rows.append(
                    (
                        (f"{ch.name}.{n + 1}", "", "", "compensator", format_sub_compensator(sub)),
                        base + ("channels", i, "compensators", n),
                    )
                )
        return rows
    if plant.format == "cascade":
        labels = {name: name.upper() for name in CASCADE} | {"ga": "Ga"}  # as sessions.build names the blocks
        return [
            ((name.upper(), "", "", t.kind, describe(t, labels[name])), base + (name,))
            for name, t in cascade_transfers(plant)
        ]
    return [
        ((f"a[{e.row},{e.col}]", "", "", "matrix entry", e.expression), base + ("entries", i))
        for i, e in enumerate(plant.entries)
    ]


CASCADE = ("g1", "g2", "g1g2", "ga", "h1", "h2")  # report 001's Figure 2, in the order the tab lists them


def cascade_transfers(plant) -> list[tuple[str, object]]:
    """(attribute, transfer) of a cascade plant's blocks that are given."""
    return [(name, t) for name in CASCADE if (t := getattr(plant, name)) is not None]


def constraint_marks(problem: Problem, states: Sequence[ConstraintState]) -> dict[str, str]:
    """For each parameter a linear constraint names: the constraints' numbers as the Targets tab
    lists them, each followed by 'binds' or 'VIOLATED' where it is so at ``states``' design."""
    marks: dict[str, list[str]] = {}
    for k, (inequality, at) in enumerate(zip(problem.inequalities, states), start=1):
        word = "" if at.state == "holds" else f" {at.state}"
        for name in dict.fromkeys(name for name, _, _ in inequality.terms):
            marks.setdefault(name, []).append(f"{k}{word}")
    return {name: ", ".join(numbers) for name, numbers in marks.items()}

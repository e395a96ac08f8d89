"""The rows of the Plant tab: one per block, junction, matrix entry, channel
or break point of every condition, each with the model path it shows."""

from __future__ import annotations

from .edits import Ref

Cells = tuple[str, str, str, str, str, str]


def plant_rows(model) -> list[tuple[Cells, Ref | None]]:
    """(condition, block, input, output, kind, definition) and the row's model path."""
    rows: list[tuple[Cells, Ref | None]] = []
    for k, condition in enumerate(model.conditions):
        rows += [((condition.name,) + cells, ref) for cells, ref in _condition_rows(condition, k)]
    return rows


def _condition_rows(condition, k: int) -> list[tuple[tuple[str, ...], Ref | None]]:
    plant, base = condition.plant, ("conditions", k, "plant")
    if plant.format == "diagram":
        rows = [((b.name, b.input, b.output, b.transfer.kind, describe(b.transfer)), base + ("blocks", i))
                for i, b in enumerate(plant.blocks)]
        rows += [((j.name, " ".join([f"+{s}" for s in j.plus] + [f"-{s}" for s in j.minus]), j.output, "junction",
                   ""), base + ("junctions", i)) for i, j in enumerate(plant.junctions)]
        rows.append((("(loop broken at)", condition.break_at, "", "", ""), ("conditions", k, "break_at")))
        return rows
    if plant.format == "channels":
        rows = []
        for i, ch in enumerate(plant.channels):
            rows.append(((f"{ch.name}.response", "e", f"{ch.name}.theta", ch.response.kind, describe(ch.response)),
                         base + ("channels", i)))
            for n, sub in enumerate(ch.compensators, start=1):
                rows.append(((f"{ch.name}.{n}", "", "", "polynomial", _polynomial(sub)), base + ("channels", i)))
        return rows
    if plant.format == "cascade":
        return [((name.upper(), "", "", t.kind, describe(t)), base + (name,))
                for name in ("g1", "g2", "g1g2", "ga", "h1", "h2") if (t := getattr(plant, name)) is not None]
    return [((f"a[{e.row},{e.col}]", "", "", "matrix entry", e.expression), base + ("entries", i))
            for i, e in enumerate(plant.entries)]


def _polynomial(transfer) -> str:
    return f"({', '.join(map(str, transfer.numerator))}) / ({', '.join(map(str, transfer.denominator))})"


def describe(transfer) -> str:
    """A one-line definition of a transfer model."""
    kind = transfer.kind
    if kind == "expression":
        return transfer.expression
    if kind == "table":
        t = transfer.table
        return f"table {t.csv or 'inline'} ({t.form}, {t.unit}, gain {t.gain:g})"
    if kind == "controller":
        factors = " ".join(f"{f.kind}({f.b if 'complex' not in f.kind else f'{f.damping},{f.frequency}'})"
                           for f in transfer.factors)
        return f"{transfer.gain} s^{transfer.s_power} {factors}"
    if kind == "polynomial":
        return _polynomial(transfer)
    if kind == "delay":
        return f"exp(-s*{transfer.tau})"
    return kind

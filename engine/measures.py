"""The tableau: every target's measures in every condition, with desired
values and whether they are met (report 000's table, generalized)."""

from __future__ import annotations


from .algorithm import MeasureRow
from .loops import loop_model
from .margins import Band, Margin, margins
from .problem import Problem, Target

# measure name -> (margin kind, attribute, at least (True) or at most (False))
MEASURES = {
    "gain_margin": ("G", "value", True),
    "phase_margin": ("P", "value", True),
    "stability_margin": ("S", "value", True),
    "attenuation_margin": ("A", "value", False),
    "gain_margin_db": ("G", "gain_db", True),
    "phase_margin_deg": ("P", "phase_deg", True),
}


def tableau(problem: Problem) -> list[MeasureRow]:
    """Rows for every target in every condition it applies to, sorted as declared."""
    rows: list[MeasureRow] = []
    for c, condition in enumerate(problem.conditions):
        targets = [t for t in problem.targets if t.condition in (None, condition.name)]
        if not targets:
            continue
        model = loop_model(condition.network, condition.break_at, problem.grid.omega, problem.values(c))
        attenuation_from = min((t.detect_low for t in targets if t.measure == "attenuation_margin"), default=None)
        found = margins(model, attenuation_above=attenuation_from)
        for target in targets:
            rows += _rows(target, found, condition.name)
    return rows


def _rows(target: Target, found, condition: str) -> list[MeasureRow]:
    if target.measure == "crossover_frequency":
        wc = found.crossover_frequency
        desired = target.bands[0].desired if target.bands else None
        value = float("nan") if wc is None else wc
        return [MeasureRow("wc", "crossover_frequency", condition, value, desired,
                           desired is None or (wc is not None and wc >= desired), wc, method=found.label)]
    kind, attribute, at_least = MEASURES[target.measure]
    band = Band(target.detect_low, target.detect_high)
    chosen: list[Margin] = [m for m in found.all() if m.kind == kind and band.contains(m.frequency)]
    rows = []
    for n, m in enumerate(chosen, start=1):
        value = float(getattr(m, attribute))
        desired = target.desired(m.frequency)
        ok = desired is None or (value >= desired if at_least else value <= desired)
        rows.append(MeasureRow(f"{kind}{n}", target.measure, condition, value, desired, bool(ok), m.frequency,
                               at_least, found.label))
    return rows


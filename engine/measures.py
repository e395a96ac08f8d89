"""The tableau: every target's measures in every condition, with desired
values and whether they are met (report 000's table, generalized)."""

from __future__ import annotations

from .algorithm import MeasureRow
from .errors import EngineError
from .guard import numerical
from .loops import loop_model
from .margins import Band, Margin, margins
from .measure_kinds import kind
from .problem import Problem, Target

# margin measure -> the attribute of its `Margin` the tableau shows (the margin family and the
# natural sense are the table's, `engine.measure_kinds`)
ATTRIBUTE = {"gain_margin": "value", "phase_margin": "value", "stability_margin": "value",
             "attenuation_margin": "value", "gain_margin_db": "gain_db", "phase_margin_deg": "phase_deg"}
TABLEAU_MEASURES = (*ATTRIBUTE, "crossover_frequency")


def tableau(problem: Problem) -> list[MeasureRow]:
    """Rows for every target in every condition it applies to, sorted as declared (numerical
    trouble on extreme values is an `EngineError`, never a warning)."""
    with numerical("tableau"):
        return _tableau(problem)


def _tableau(problem: Problem) -> list[MeasureRow]:
    unknown = [t.measure for t in problem.targets if t.measure not in TABLEAU_MEASURES]
    if unknown:
        raise EngineError(f"the tableau evaluates {', '.join(TABLEAU_MEASURES)}, not {unknown[0]!r} "
                          "(slp's own tableau evaluates every measure)")
    rows: list[MeasureRow] = []
    for c, condition in enumerate(problem.conditions):
        targets = [t for t in problem.targets if t.condition in (None, condition.name)]
        if not targets:
            continue
        model = loop_model(condition.network, condition.break_at, problem.grid.omega, problem.condition_values(c))
        attenuation_from = min((t.detect_low for t in targets if t.measure == "attenuation_margin"), default=None)
        found = margins(model, attenuation_above=attenuation_from)
        for target in targets:
            rows += _rows(target, found, condition.name)
    return rows


def _met(value: float, desired: float | None, at_least: bool) -> bool:
    return desired is None or (value >= desired if at_least else value <= desired)


def _rows(target: Target, found, condition: str) -> list[MeasureRow]:
    at_least = target.at_least  # the measure's natural sense (the table's) unless the target names one
    if target.measure == "crossover_frequency":
        wc = found.crossover_frequency
        desired = target.bands[0].desired if target.bands else None
        value = float("nan") if wc is None else wc
        return [MeasureRow("wc", "crossover_frequency", condition, value, desired,
                           desired is None or (wc is not None and _met(wc, desired, at_least)), wc, at_least,
                           found.label)]
    family, attribute = kind(target.measure).margin, ATTRIBUTE[target.measure]
    band = Band(target.detect_low, target.detect_high)
    chosen: list[Margin] = [m for m in found.all() if m.kind == family and band.contains(m.frequency)]
    rows = []
    for n, m in enumerate(chosen, start=1):
        value = float(getattr(m, attribute))
        desired = target.desired(m.frequency)
        ok = _met(value, desired, at_least)
        rows.append(MeasureRow(f"{family}{n}", target.measure, condition, value, desired, bool(ok), m.frequency,
                               at_least, found.label))
    return rows


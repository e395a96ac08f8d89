"""What the session's targets require, as the plots draw it: each target band's
requirement with the verdict of the current design's tableau (met, not met, or not yet
judged), named as the legend shows it."""

from __future__ import annotations

import math
from dataclasses import dataclass

from engine.design.measure_kinds import EVERY_BREAK, MEASURE_KINDS
from engine.design.problem import FREQUENCY_MEASURES, Target
from tui.state.views import View

SYMBOLS = {"gain_margin_db": "GM", "phase_margin_deg": "PM", "crossover_frequency": "wc"}
MET_STYLE = {"color": "gray"}
UNMET_STYLE = {"color": "red"}
SHADE = "░"  # the marker of the points shading a region that violates a requirement


@dataclass(frozen=True)
class Requirement:
    """One band of one target: ``value`` required of ``measure`` (at least, or at most)
    for frequencies in [low, high]; ``met``: the current design's verdict (None: no
    iteration judged it yet)."""

    measure: str
    value: float
    at_least: bool
    low: float
    high: float
    met: bool | None
    settling_band: float = 0.05  # a time target's response: the settling band and the reference
    reference: float = 1.0

    @property
    def label(self) -> str:
        """The legend's name of it: "PM >= 45 deg target: not met"."""
        kind = MEASURE_KINDS.get(self.measure)
        name = SYMBOLS.get(self.measure, kind.short if kind else self.measure)
        unit = f" {kind.unit}" if kind and kind.unit else ""
        verdict = {True: "met", False: "NOT met", None: "not judged"}[self.met]
        return f"{name} {'>=' if self.at_least else '<='} {self.value:g}{unit} target: {verdict}"

    @property
    def style(self) -> dict[str, str]:
        """Drawn quietly when met, in red when violated."""
        return UNMET_STYLE if self.met is False else MET_STYLE


def requirements(view: View, iteration: int | None = None) -> list[Requirement]:
    """Every requirement band of the view's targets on the plotted condition (all
    conditions when several are plotted), judged by an iteration's tableau (None: the
    current one; iteration 0: the start's)."""
    rows, _ = view.tableau(iteration)
    if not rows and view.initial is not None:
        rows = list(view.initial.measures)
    plotted = {view.problem.conditions[k].name for k in view.plotted()} if view.problem.conditions else set()
    out = []
    for target in view.problem.targets:
        if not target.requirement or (target.condition is not None and target.condition not in plotted):
            continue
        if not _on_plotted_loop(view, target):
            continue
        at = _row_break(view, target)
        judged = [
            r.satisfied
            for r in rows
            if r.kind == target.measure and (not plotted or r.condition in plotted) and r.name.partition("@")[2] == at
        ]
        met = all(judged) if judged else None
        response = target.response
        timing = (response.settling_band, response.reference) if response is not None else ()
        for band in target.bands:
            if math.isfinite(band.requirement):
                found = Requirement(
                    target.measure, band.requirement, target.at_least, band.low, band.high, met, *timing
                )
                out.append(found)
    return out


def _on_plotted_loop(view: View, target: Target) -> bool:
    """Whether a target's requirement belongs on the loop the plots draw: a measure read at one
    loop break (`FREQUENCY_MEASURES`) when that break is the one drawn in the first plotted
    condition; any other (a pole, a time response, the multi-loop disk margin) always."""
    if target.measure not in FREQUENCY_MEASURES or target.measure in EVERY_BREAK or not view.problem.conditions:
        return True
    k = view.first_plotted
    return target.break_in(view.problem.conditions[k]) == view.break_of(k)


def _row_break(view: View, target: Target) -> str:
    """The break a target's rows name (NAME@BREAK: read at another break than the first plotted
    condition's primary one), '' for the primary break's."""
    if target.loop_break is None or not view.problem.conditions:
        return ""
    return "" if target.loop_break == view.problem.conditions[view.first_plotted].break_at else target.loop_break

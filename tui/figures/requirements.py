"""What the session's targets require, as the plots draw it: each target band's
requirement with the verdict of the current design's tableau (met, not met, or not yet
judged), named as the legend shows it."""

from __future__ import annotations

import math
from dataclasses import dataclass

from engine.design.measure_kinds import MEASURE_KINDS
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
        judged = [r.satisfied for r in rows if r.kind == target.measure and (not plotted or r.condition in plotted)]
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

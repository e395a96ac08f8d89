"""The tableau: every target's measures in every condition, with desired
values and whether they are met (report 000's table, generalized)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from engine.design.measure_kinds import absence, kind, met
from engine.design.problem import Problem, Target
from engine.errors import EngineError
from engine.loop.design import closed_loop_realization
from engine.loop.realization import StateSpace
from engine.loop.responses import LoopModel, loop_model
from engine.margins.peak_measures import CLOSED_LOOP_MEASURES, PEAK_MEASURES, band_delay, band_peak, stable_realization
from engine.margins.search import Band, Margin, Margins, margins
from engine.model.bilinear import s_of_z, z_of_w
from engine.stepping.guard import numerical
from engine.stepping.protocol import MeasureRow

# margin measure -> the attribute of its `Margin` the tableau shows (the margin family and the
# natural sense are the table's, `engine.design.measure_kinds`)
ATTRIBUTE = {
    "gain_margin": "value",
    "phase_margin": "value",
    "stability_margin": "value",
    "attenuation_margin": "value",
    "gain_margin_db": "gain_db",
    "phase_margin_deg": "phase_deg",
}
TABLEAU_MEASURES = (*ATTRIBUTE, "crossover_frequency", *CLOSED_LOOP_MEASURES)


def tableau(problem: Problem, require_stable: bool = False) -> list[MeasureRow]:
    """Rows for every target in every condition it applies to, sorted as declared, each named as
    slp's rows are (the measure's tag and its count in the condition: WC1, GM1, PM2; a target at
    another loop break than the condition's counts apart and names it: PM1@u_rate); with
    ``require_stable`` a stability row (STAB, the stability abscissa, met when positive) for each
    rational condition no stability target covers (numerical trouble on extreme values is an
    `EngineError`, never a warning)."""
    with numerical("tableau"):
        rows = _tableau(problem)
        if require_stable:
            rows += _stability_rows(problem, rows)
        return rows


def stability_abscissa(ss: StateSpace, sample_time: float | None = None) -> float:
    """-max Re(closed-loop pole): positive when the closed loop is stable (inf with no states).  A
    sampled loop's realization is in w: its poles' s-plane equivalents s = ln(z)/T, z = (1 + w)/(1 - w),
    give -max ln|z|/T."""
    if ss.A.size == 0:
        return math.inf
    poles = np.linalg.eigvals(ss.A)
    if sample_time is None:
        return float(-np.max(poles.real))
    return float(-np.max(s_of_z(z_of_w(poles), sample_time).real))


def _stability_rows(problem: Problem, rows: list[MeasureRow]) -> list[MeasureRow]:
    covered = {r.condition for r in rows if r.kind == "stability_abscissa"}
    found = []
    for c, condition in enumerate(problem.conditions):
        if condition.name in covered or not condition.network.rational:
            continue
        tag = kind("stability_abscissa").tag
        method = "closed-loop poles (eigenvalues of the closed loop's realization)"
        try:
            ss = closed_loop_realization(condition.network, condition.break_at, problem.condition_values(c))
            value = stability_abscissa(ss, condition.network.sample_time)
        except (EngineError, np.linalg.LinAlgError) as exc:  # no closed loop to read: the row says why, unmet
            value, method = math.nan, f"no closed-loop realization: {exc}"
        found.append(MeasureRow(tag, "stability_abscissa", condition.name, value, 0.0, value > 0, None, True, method))
    return found


def _tableau(problem: Problem) -> list[MeasureRow]:
    unknown = [t.measure for t in problem.targets if t.measure not in TABLEAU_MEASURES]
    if unknown:
        raise EngineError(
            f"the tableau evaluates {', '.join(TABLEAU_MEASURES)}, not {unknown[0]!r} "
            "(slp's own tableau evaluates every measure)"
        )
    rows: list[MeasureRow] = []
    for c, condition in enumerate(problem.conditions):
        targets = [t for t in problem.targets if t.condition in (None, condition.name)]
        if not targets:
            continue
        attenuation_from = min((t.detect_low for t in targets if t.measure == "attenuation_margin"), default=None)
        stable = _stable(problem, c) if any(t.measure in CLOSED_LOOP_MEASURES for t in targets) else None
        loops: dict[str, tuple[LoopModel, Margins]] = {}  # by break: each loop a target reads, formed once
        counts: dict[tuple[str, str], int] = {}
        for target in targets:
            at = target.break_in(condition)
            if at not in loops:
                model = loop_model(condition.network, at, problem.grid.omega, problem.condition_values(c))
                loops[at] = model, margins(model, attenuation_above=attenuation_from)
            model, found = loops[at]
            if target.measure in CLOSED_LOOP_MEASURES:
                found_rows = _closed_loop_rows(target, model, found, condition.name, stable)
            else:
                found_rows = _rows(target, found, condition.name, model)
            suffix = "" if at == condition.break_at else f"@{at}"  # a row at another break names it
            for row in found_rows:
                counts[row.kind, at] = counts.get((row.kind, at), 0) + 1
                rows.append(replace(row, name=f"{kind(row.kind).tag}{counts[row.kind, at]}{suffix}"))
    return rows


def _stable(problem: Problem, c: int) -> bool | None:
    """Closed-loop stability of a rational condition from its poles (None: not rational)."""
    condition = problem.conditions[c]
    if not condition.network.rational:
        return None
    ss = closed_loop_realization(condition.network, condition.break_at, problem.condition_values(c))
    return stable_realization(ss.A)


def _closed_loop_rows(target: Target, model, found, condition: str, stable: bool | None) -> list[MeasureRow]:
    """One row per band: the disk margin, Ms or Mt refined over it (`engine.margins.peak_measures`), or the
    smallest delay margin of its gain crossovers (inf with none)."""
    rows, at_least = [], target.at_least
    for band in target.bands:
        if target.measure in PEAK_MEASURES:
            value, frequency, peak = band_peak(model, target.measure, Band(band.low, band.high), stable)
            method = peak.method
        else:
            (value, frequency), method = band_delay(found, Band(band.low, band.high), stable), found.label
            if stable is False:
                method = "the closed loop is unstable: no delay is tolerated"
        rows.append(
            MeasureRow(
                "",  # named by `_tableau`
                target.measure,
                condition,
                value,
                band.desired,
                bool(met(value, band.desired, at_least)),
                None if np.isnan(frequency) else frequency,
                at_least,
                method,
            )
        )
    return rows


def _rows(target: Target, found, condition: str, model: LoopModel) -> list[MeasureRow]:
    at_least = target.at_least  # the measure's natural sense (the table's) unless the target names one
    if target.measure == "crossover_frequency":
        wc = found.crossover_frequency
        desired = target.bands[0].desired if target.bands else None
        value, method = (wc, found.label) if wc is not None else _no_crossover(model)
        return [
            MeasureRow(
                "",  # named by `_tableau`
                "crossover_frequency",
                condition,
                value,
                desired,
                met(value, desired, at_least),
                wc,
                at_least,
                method,
            )
        ]
    family, attribute = kind(target.measure).margin, ATTRIBUTE[target.measure]
    band = Band(target.detect_low, target.detect_high)
    chosen: list[Margin] = [m for m in found.all() if m.kind == family and band.contains(m.frequency)]
    rows = []
    for m in chosen:
        value = float(getattr(m, attribute))
        desired = target.desired(m.frequency)
        ok = met(value, desired, at_least)
        rows.append(
            MeasureRow("", target.measure, condition, value, desired, bool(ok), m.frequency, at_least, found.label)
        )
    return rows


def _no_crossover(model: LoopModel) -> tuple[float, str]:
    """A loop without a gain crossover stands at 0 (|GH| < 1 everywhere: no bandwidth) or at
    infinity (|GH| > 1 everywhere), with the reason (`engine.design.measure_kinds.absence`)."""
    found = absence("crossover_frequency", np.abs(model.gh[model.omega > 0]))
    return found if found is not None else (float("nan"), "no crossover, and no |GH| to judge it by")

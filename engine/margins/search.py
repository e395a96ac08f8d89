"""Margins of an open loop GH(j omega), as in report 000 and classically.

Four kinds, each a distance (report 000, chapter II and the CIP listing):
  G  gain margin: where Im GH changes sign with Re GH < 0; value |1 + GH|;
  P  phase margin: where |GH| = 1; value |1 + GH| = 2 sin(|theta|/2);
  S  stability margin: local minimum of |1 + GH| over frequency;
  A  attenuation margin: local maximum of |GH| above a given frequency.
Classical forms ride along: gain margin in dB (-20 log10 |GH|), phase margin
in degrees (180 + angle GH, wrapped to (-180, 180]), delay margin.

Rational loops (`LoopModel.rational`) are searched over all frequencies on a
detection grid built from the blocks' corner frequencies (dense around lightly
damped poles and zeros), and every crossing or extremum is refined between
grid points to machine precision on the exact response, so no result depends
on the user's grid.  Loops with a delay are refined the same way within the
user's grid range.  Tabulated loops are refined the same way on a rational
fit of the table (``method = "fitted"``, with its residual); the grid rule of
the CIP listing (subroutines GAINMG, PHASEM, SRMINS: the grid point nearest
the sign change, or the grid extremum) is ``method = "grid"``.  The whole
method, with its bounds: docs/margins.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.tabulated_step import has_tables
from engine.derived import Form
from engine.errors import EngineError
from engine.loop.design import design
from engine.loop.fit_cache import cached_fit, content_key
from engine.loop.pole_zero import ZpkEvaluator
from engine.loop.responses import Evaluator, LoopModel, LoopSource, SampledLoop, loop_model
from engine.margins.detection_grid import NOISE, Detection, detection_grid
from engine.margins.pole_zero.levels import LoopLevels, log_distance
from engine.margins.pole_zero.search import fast_margins
from engine.margins.sampled import sampled_margins
from engine.margins.shape_notes import level_notes, shape_notes
from engine.margins.values import FAMILY_LOWEST, Band, Margin, Margins, family, margins_of, single_margin
from engine.model.blocks import FittedTableTransfer, TabulatedTransfer
from engine.model.network import Network
from engine.numerics.rational_fit import Trend
from engine.numerics.refinement import Job, Roots, refine, refine_together, sign_changes


def margins(
    loop: LoopModel,
    gain_band: Band = Band(),
    phase_band: Band = Band(),
    attenuation_above: float | None = None,
    method: str = "auto",
) -> Margins:
    """All four margin kinds of ``loop`` (attenuation only when a frequency is given).

    Loops with an evaluator are refined on it.  A tabulated loop is, by
    default (``"auto"`` or ``"fitted"``), refined on a rational fit of its
    table (`engine.numerics.rational_fit`), its residual stated; ``method="grid"`` (or a
    fit worse than `FIT_LIMIT`) takes report 000's grid rule instead."""
    if method not in ("auto", "fitted", "grid"):
        raise ValueError(f"margin method must be auto, fitted or grid, not {method!r}")
    return loop.derived.get(
        MARGINS,
        lambda: _margins(loop, gain_band, phase_band, attenuation_above, method),
        gain_band,
        phase_band,
        attenuation_above,
        _method_key(loop, method),
    )


def _method_key(loop: LoopModel, method: str) -> str:
    """The method as far as a loop's margins depend on it: a loop with an evaluator is refined on it
    whatever the method; a sampled loop is searched on its w-plane form, which may have none."""
    if isinstance(loop, SampledLoop):
        return _method_key(loop.w_plane, method)
    return method if loop.evaluate is None else "exact"


MARGINS: Form[Margins] = Form("margins")  # on a loop: asked with the bands, the attenuation's start and the method


def _margins(
    loop: LoopModel, gain_band: Band, phase_band: Band, attenuation_above: float | None, method: str
) -> Margins:
    """`margins`, found (kept on the loop: a loop is not changed, and `loop_model` gives one per design)."""
    if isinstance(loop, SampledLoop):
        return sampled_margins(loop, margins, gain_band, phase_band, attenuation_above, method)
    if loop.evaluate is None:
        fitted = None if method == "grid" else fitted_loop(loop)
        if fitted is None:
            result = _grid_margins(loop, gain_band, phase_band, attenuation_above)
            return (
                result
                if method == "grid"
                else replace(
                    result,
                    notes=result.notes
                    + (f"the table could not be fitted within {FIT_LIMIT:g} relative: grid rule used",),
                )
            )
        found = supported(loop, margins(fitted.model, gain_band, phase_band, attenuation_above), fitted.residual)
        notes = tuple(n for n in found.notes if not n.startswith("searched within"))
        return replace(
            found,
            method="fitted",
            residual=fitted.residual,
            notes=(
                f"tabulated loop: margins refined on {fitted.how} "
                f"(relative residual {fitted.residual:.1e} at every table point, the margins' stated uncertainty)",
            )
            + notes,
        )
    return _searched(loop, gain_band, phase_band, attenuation_above)[0]


def margins_alongside(
    loop: LoopModel, job: Job | None, attenuation_above: float | None = None
) -> tuple[Margins, Roots | None]:
    """``margins(loop, attenuation_above=...)``, and another search's brackets on the same loop (``job``,
    e.g. the closed-loop peaks') refined in the same steps as the margins' own when those are refined on
    a detection grid: their `Roots`, as `refine` gives them alone; None when the margins took another way
    (the caller refines them itself)."""
    if isinstance(loop, SampledLoop) or loop.evaluate is None:
        return margins(loop, attenuation_above=attenuation_above), None
    return _searched(loop, Band(), Band(), attenuation_above, job)


def _searched(
    loop: LoopModel, gain_band: Band, phase_band: Band, attenuation_above: float | None, job: Job | None = None
) -> tuple[Margins, Roots | None]:
    """The margins of a loop with an evaluator (`margins`), and ``job``'s roots when refined with them."""
    grid, (found, notes), shared = None, _without_grid(loop), None
    if found is None:
        grid = detection_grid(loop)
        found, shared = _refined_alongside(loop, grid, job)
    if loop.exact is not loop.evaluate and not getattr(loop.evaluate, "factored", False):
        off = _disagreement(loop, found)
        if off > AGREEMENT:  # the pole-zero form is off where it matters: refine on the network
            loop = loop.on_exact()
            found = _polished(loop, found) if off <= POLISH_LIMIT else None
            if found is None:  # or search it, from the form's grid
                grid = detection_grid(loop, seed=None if grid is None else grid.omega)
                found = _refined(loop, grid)
    gain = [m for m in found["G"] if m.gh.real < 0]
    dc = loop.dc_value
    if dc is not None and dc.real < 0:
        gain = [single_margin("G", 0.0, dc)] + [m for m in gain if m.frequency > 0]
    if grid is not None:
        notes = list(grid.notes) + shape_notes(loop, grid) + _few_delay_margins(loop, grid, len(gain))
    if not loop.rational:
        lo, hi = (loop.omega[0], loop.omega[-1]) if grid is None else (grid.omega[0], grid.omega[-1])
        notes.insert(
            0,
            f"searched within {lo:.6g}..{hi:.6g} rad/s (the plot grid's range joined with what the loop's corners and crossovers need)",
        )
    above = float("inf") if attenuation_above is None else attenuation_above
    stability = found["S"]
    families = tuple(f for f in (family("G", gain, loop.delay), family("S", stability, loop.delay)) if f is not None)
    found_margins = Margins(
        gain=tuple(m for m in gain if gain_band.contains(m.frequency)),
        phase=tuple(m for m in found["P"] if phase_band.contains(m.frequency)),
        stability=tuple(stability),
        attenuation=tuple(m for m in found["A"] if m.frequency >= above),
        method="refined",
        notes=tuple(notes),
        crossovers_beyond=None if grid is None else grid.crossovers_beyond,
        families=families,
    )
    return found_margins, shared


def _few_delay_margins(loop: LoopModel, grid: Detection, found: int) -> list[str]:
    """A delay loop crosses the negative real axis without end: fewer than the `FAMILY_LOWEST`
    lowest gain margins found means its search stopped below them (said where it stopped)."""
    if not (loop.delay > 0 and found < FAMILY_LOWEST):
        return []
    return [
        f"{found} gain margin(s) found, fewer than the {FAMILY_LOWEST} lowest: the search stops at "
        f"{grid.omega[-1]:.6g} rad/s and the delay's crossings of the negative real axis go on above it"
    ]


def _without_grid(loop: LoopModel) -> tuple[dict[str, list[Margin]] | None, list[str]]:
    """The margins of a loop in pole-zero form found without a detection grid
    (`engine.margins.pole_zero.search`) and what its constant levels mean (`engine.margins.shape_notes`);
    (None, []) when that method does not apply."""
    if not (loop.rational and isinstance(loop.evaluate, ZpkEvaluator)):
        return None, []
    frequencies = fast_margins(loop.evaluate)
    if frequencies is None:
        return None, []
    values = _evaluated(loop, frequencies)
    levels = LoopLevels.of(loop.evaluate)
    notes = level_notes(loop, levels.constant, levels.sample) if levels.constant else []
    return {name: margins_of(name, frequencies[name], values[name]) for name in ("G", "P", "S", "A")}, notes


AGREEMENT = 0.0  # relative: a form of GH off the network by more at a margin has its margins polished there
# (it was 1e-11: a realization's form kept margins 9e-12 off the network; batched studies polish every one)
POLISH_LIMIT = 1e-9  # relative: a form off by no more (its admission, `engine.loop.pole_zero`) has its margins polished
POLISH_WIDTHS = (1e-9, 1e-7, 1e-5)  # relative half-widths of the brackets tried around a margin to polish


def _disagreement(loop: LoopModel, found: dict[str, list[Margin]]) -> float:
    """The largest relative difference between the fast form and the exact network
    at the margins found (it was checked at five spread-out frequencies only; near
    clustered light roots it can be off in the seventh digit); inf when the network fails."""
    every = [m for kind in found.values() for m in kind]
    if not every:
        return 0.0
    w = np.array([m.frequency for m in every])
    fast = np.array([m.gh for m in every])
    try:
        exact = loop.exact(w)[0]
    except EngineError:
        return float("inf")
    with np.errstate(all="ignore"):
        off = np.abs(exact - fast) / np.abs(exact)
    return float(off.max()) if np.isfinite(off).all() else float("inf")


def _polished(loop: LoopModel, found: dict[str, list[Margin]]) -> dict[str, list[Margin]] | None:
    """The fast form's margins refined again on ``loop`` (the exact network), each
    in the narrowest bracket of `POLISH_WIDTHS` around it across which the
    network's level changes sign as the form's did: the same features, each
    exact to 4 ulp.  None when a margin has no such bracket or two of one
    kind share one (the network is then searched in full)."""
    names = ("G", "P", "S", "A")
    counts = [len(found[name]) for name in names]
    centre = np.array([m.frequency for name in names for m in found[name]])
    levels = [replace(LEVELS[name], reveals="") for name in names]  # each crossing has its own bracket
    kind = np.repeat(np.arange(len(names)), counts)
    if not (centre > 0).all():
        return None
    ends = np.full((2, centre.size), np.nan)  # each bracket's ends, and GH and dGH there
    g, dg = np.zeros((2, centre.size), dtype=complex), np.zeros((2, centre.size), dtype=complex)
    for width in POLISH_WIDTHS:
        todo = np.flatnonzero(np.isnan(ends[0]))
        if todo.size == 0:
            break
        at = np.array([centre[todo] * (1 - width), centre[todo] * (1 + width)])
        try:
            value, slope = (v.reshape(2, todo.size) for v in loop.evaluate(at.ravel()))
        except EngineError:
            return None
        across = todo[_changes_sign([levels[k] for k in kind[todo]], value[0], slope[0], value[1], slope[1])]
        ends[:, across], g[:, across], dg[:, across] = (x[:, np.isin(todo, across)] for x in (at, value, slope))
    separate = (ends[0, 1:] > ends[1, :-1]) | (kind[1:] != kind[:-1])
    if np.isnan(ends).any() or not separate.all():
        return None
    roots = _refine(loop, (ends[0], g[0], dg[0]), (ends[1], g[1], dg[1]), levels, counts).at
    if not ((roots >= ends[0]) & (roots <= ends[1])).all():
        return None
    bounds = np.cumsum([0] + counts)
    frequencies = {name: roots[bounds[k] : bounds[k + 1]] for k, name in enumerate(names)}
    values = _evaluated(loop, frequencies)
    return {name: margins_of(name, frequencies[name], values[name]) for name in names}


def _changes_sign(levels: list[Level], g_lo: NDArray, dg_lo: NDArray, g_hi: NDArray, dg_hi: NDArray) -> NDArray:
    """Per bracket, does its level's target (h for a crossing, h' for an extremum)
    change sign across it, in the level's direction, both ends above the rounding
    noise (relative `NOISE`, as the detection grid's brackets)?"""
    shift, angle = np.array([lv.shift for lv in levels]), np.array([lv.angle for lv in levels], dtype=bool)
    _, _, (h_lo, d_lo), (h_hi, d_hi) = _end_levels(shift, angle, (g_lo, dg_lo), (g_hi, dg_hi))
    stationary = np.array([lv.stationary for lv in levels], dtype=bool)
    a, b = np.where(stationary, d_lo, h_lo), np.where(stationary, d_hi, h_hi)
    with np.errstate(all="ignore"):  # the slopes' sizes (h is a log or an angle: its own size is 1)
        size_a = np.where(stationary, np.abs(dg_lo / (g_lo + shift)), 1.0)
        size_b = np.where(stationary, np.abs(dg_hi / (g_hi + shift)), 1.0)
    loud = (np.abs(a) > NOISE * size_a) & (np.abs(b) > NOISE * size_b)
    direction = np.array([lv.direction for lv in levels])
    turns = np.where(direction > 0, (a < 0) & (b > 0), np.where(direction < 0, (a > 0) & (b < 0), a * b < 0))
    return turns & loud


FIT_LIMIT = 0.05  # a fit off by more than this (relative) is no better than the grid
SUPPORT = 3.0  # the fit between two table points may leave their magnitudes' range by this factor
SUPPORT_PHASE = 30.0  # ... and their phases' range by this many degrees


def supported(table: LoopModel, found: Margins, residual: float) -> Margins:
    """The fitted margins the table supports, and a note for the others.  A margin between
    two table points stands when the fit there stays within `SUPPORT` of the magnitudes and
    `SUPPORT_PHASE` of the phases of the two points (a fit of a table spanning 20 decades
    placed |GH| = 1.56 where the points around said 4e-5: a crossover the table never had),
    and a gain margin also when the phase leaves -180 deg by more than the fit's uncertainty
    (asin of the residual) at a point on either side (a loop whose phase is -180 deg to
    rounding over decades, 1/s^2, has a phase crossing at every rounding error)."""
    omega, gh = table.omega[table.omega > 0], table.gh[table.omega > 0]
    dropped: dict[str, int] = {}

    def stands(m: Margin) -> bool:
        k = int(np.searchsorted(omega, m.frequency))
        if k == 0 or k >= omega.size:  # at or beyond an end of the table: no bracket to judge by
            return True
        pair = gh[k - 1 : k + 1]
        magnitude, phase = np.abs(pair), np.unwrap(np.angle(pair))
        fit_phase = phase[0] + np.angle(m.gh / pair[0])
        ok = (
            magnitude.min() / SUPPORT <= abs(m.gh) <= magnitude.max() * SUPPORT
            and np.degrees(phase.min() - fit_phase) <= SUPPORT_PHASE
            and np.degrees(fit_phase - phase.max()) <= SUPPORT_PHASE
        )
        if ok and m.kind == "G":
            ok = _phase_resolved(gh, k, residual)
        if not ok:
            dropped[m.kind] = dropped.get(m.kind, 0) + 1
        return ok

    kept = replace(
        found,
        gain=tuple(filter(stands, found.gain)),
        phase=tuple(filter(stands, found.phase)),
        stability=tuple(filter(stands, found.stability)),
    )
    if not dropped:
        return kept
    counts = ", ".join(f"{n} {KIND_NAMES[kind]}" for kind, n in sorted(dropped.items()))
    return replace(
        kept,
        notes=kept.notes
        + (
            f"{counts} of the fit dropped: the table does not support them (the fit leaves its points' "
            f"range between them, or the phase is -180 deg within the fit's uncertainty there)",
        ),
    )


KIND_NAMES = {"G": "gain margin(s)", "P": "phase margin(s)", "S": "stability margin(s)"}


def _phase_resolved(gh: NDArray, k: int, residual: float) -> bool:
    """Does the table's phase leave -180 deg by more than the fit's uncertainty at the
    points on both sides of the crossing between points k - 1 and k (three points out)?"""
    uncertainty = np.arcsin(min(1.0, 2.0 * max(residual, 1e-15)))
    away = np.abs(np.angle(-gh))  # distance from -180 deg, rad
    before, after = away[max(0, k - 3) : k], away[k : k + 3]
    if before.size and after.size and before.max() > uncertainty and after.max() > uncertainty:
        return True
    return _straddled(gh[k - 1 : k + 1], away[k - 1 : k + 1], uncertainty)


def _straddled(pair: NDArray, away: NDArray, uncertainty: float) -> bool:
    """Do the two table points themselves lie on either side of the negative real axis (Re < 0,
    Im of opposite signs), one of them beyond the fit's uncertainty?  Then the crossing is the
    table's, whatever the fit (python-control's frd case: -176.4 and -213.1 deg at |GH| = 0.6,
    the first 3.6 deg from -180, within a fit's 3.8)."""
    return bool(
        pair.size == 2 and np.all(pair.real < 0) and pair[0].imag * pair[1].imag < 0 and away.max() > uncertainty
    )


@dataclass(frozen=True)
class FittedLoop:
    """A tabulated loop made rational (``model``, searched within the table's range), its largest
    relative residual on the table's points, its degree and how it was made (``how``)."""

    model: LoopModel
    residual: float
    degree: int
    how: str


def fitted_loop(loop: LoopModel) -> FittedLoop | None:
    """A rational form of a tabulated loop: its network with each table's own fit in the table's place
    (`_through_table_fits`: a table's fit is made once, so a new design fits nothing) where that meets the
    loop's values on the table within `FIT_LIMIT`, else a fit of the whole loop (`_whole_loop_fit`: one per
    design); None when neither does."""
    return _through_table_fits(loop) or _whole_loop_fit(loop)


THROUGH_FITS: Form[FittedLoop | None] = Form("loop through the tables' fits")  # on a design, per break and table


def _through_table_fits(loop: LoopModel) -> FittedLoop | None:
    """The loop's network with each table replaced by its own rational fit (`_trended_fit`, made once per
    table's content), the rest exact; None without a network of tables and rational parts or delays, when
    a table does not fit, or when the loop so evaluated misses its values on the table by more than
    `FIT_LIMIT` (relative: in a feedback structure a table's residual is not the loop's).  Made once per
    design (kept on it: its margins, peaks and gain solves share it), break and loop values."""
    source = loop.source
    if source is None or not has_tables(source.network):
        return None
    return design(source.network, source.params).derived.get(
        THROUGH_FITS, lambda: _made_through_table_fits(loop, source), source.break_at, content_key(loop.omega, loop.gh)
    )


def _made_through_table_fits(loop: LoopModel, source: LoopSource) -> FittedLoop | None:
    """`_through_table_fits`, made."""
    entries, corners, dampings, degree = [], [np.zeros(0)], [np.zeros(0)], 0
    for e in source.network.entries:
        if isinstance(e.transfer, TabulatedTransfer):
            table = e.transfer.table
            keep = table.omega > 0
            fitted = _trended_fit(table.omega[keep], table.response[keep])
            if fitted is None:
                return None
            corners, dampings = corners + [fitted.corners], dampings + [fitted.dampings]
            degree += fitted.degree
            e = replace(e, transfer=FittedTableTransfer(fitted.evaluate, f"fit of {e.transfer.text}"))
        entries.append(e)
    network = Network(source.network.signals, source.network.inputs, tuple(entries), source.network.variable)
    try:
        exact = loop_model(network, source.break_at, loop.omega, source.params)
        residual = _relative_residual(exact.evaluate, loop.omega, loop.gh)
    except EngineError:
        return None
    if not residual <= FIT_LIMIT:
        return None
    model = LoopModel(
        loop.omega,
        loop.gh,
        exact.evaluate,
        np.concatenate([exact.corner_frequencies, *corners]),
        np.concatenate([exact.dampings, *dampings]),
        delay=exact.delay,
        axis_poles=exact.axis_poles,
        exact=exact.exact,
    )
    return FittedLoop(
        model, residual, degree, f"the network with each table's rational fit in its place (degree {degree})"
    )


def _whole_loop_fit(loop: LoopModel) -> FittedLoop | None:
    """A rational fit of the whole tabulated loop as a loop model, searched within the table's range;
    None when it fits badly."""
    keep = loop.omega > 0
    omega, gh = loop.omega[keep], loop.gh[keep]
    fitted = _trended_fit(omega, gh)
    if fitted is None:
        return None
    residual = _relative_residual(fitted.evaluate, omega, gh)
    if not residual <= FIT_LIMIT:
        return None
    model = LoopModel(omega, gh, fitted.evaluate, fitted.corners, fitted.dampings)
    return FittedLoop(model, residual, fitted.degree, f"a rational fit of the whole loop (degree {fitted.degree})")


@dataclass(frozen=True)
class TrendedFit:
    """A response's AAA fit times its trend (`Trend`): values and slopes d/domega at any frequencies, the
    corners and dampings of its poles (and the trend's corner), its degree."""

    evaluate: Evaluator
    corners: NDArray[np.float64]
    dampings: NDArray[np.float64]
    degree: int


def _trended_fit(omega: NDArray[np.float64], response: NDArray[np.complex128]) -> TrendedFit | None:
    """The fit of ``response`` (above 0 rad/s) normalized by its trend (`cached_fit`: once per content);
    None when it cannot be fitted."""
    trend = Trend.of(omega, response)
    try:
        with np.errstate(all="ignore"):
            fit = cached_fit(omega, response / trend.evaluate(omega)[0])
    except EngineError:
        return None

    def evaluate(w: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        (g, dg), (t, dt) = fit.evaluate(w), trend.evaluate(w)
        return g * t, dg * t + g * dt

    poles = fit.poles[np.isfinite(fit.poles) & (np.abs(fit.poles) > 0)]
    bent = trend.low != trend.high
    corners = np.concatenate([np.abs(poles), [trend.corner] if bent else []])
    dampings = np.concatenate([np.abs(poles.real) / np.abs(poles), [1.0] if bent else []])
    return TrendedFit(evaluate, corners, dampings, int(fit.degree + abs(trend.low - trend.high) + abs(trend.low)))


def _relative_residual(evaluate: Evaluator, omega: NDArray[np.float64], gh: NDArray[np.complex128]) -> float:
    """The largest relative miss of ``evaluate`` on the loop's values ``gh`` at ``omega`` (above 0 rad/s)."""
    keep = (omega > 0) & (gh != 0)
    with np.errstate(all="ignore"):  # judged point by point, relative to each point's value
        relative = np.abs(evaluate(omega[keep])[0] - gh[keep]) / np.abs(gh[keep])
    return float(np.max(relative, initial=0.0)) if np.all(np.isfinite(relative)) else math.inf


def _refined(loop: LoopModel, grid: Detection) -> dict[str, list[Margin]]:
    """Every crossing and extremum, refined together in one vectorized loop.

    The detection grid leaves at most one extremum of |GH|, of |1 + GH| and
    of arg GH in an interval, so an interval whose ends differ in sign holds
    exactly one crossing, and one whose ends agree holds two or none: two
    when the extremum inside lies across the level.  Those extrema are
    watched while they are refined (`refine`'s ``hiding``): extrema of |GH|
    for gain crossovers, extrema of the phase for phase crossovers.
    """
    return _refined_alongside(loop, grid, None)[0]


def _refined_alongside(
    loop: LoopModel, grid: Detection, job: Job | None
) -> tuple[dict[str, list[Margin]], Roots | None]:
    """`_refined`, and ``job``'s roots refined in the same steps (None without a job)."""
    w, gh, dgh = grid.omega, grid.gh, grid.dgh
    brackets = _grid_brackets(w, gh, dgh, grid.flat)
    if loop.axis_poles.size:
        brackets = {name: _off_poles(b, w, loop.axis_poles) for name, b in brackets.items()}
    names = list(brackets)
    index = np.concatenate([brackets[name].index for name in names])
    counts = [brackets[name].index.size for name in names]
    mine = _job(
        loop,
        (w[index], gh[index], dgh[index]),
        (w[index + 1], gh[index + 1], dgh[index + 1]),
        [LEVELS[name] for name in names],
        counts,
    )
    roots, shared = refine_together([mine, job]) if job is not None else (refine(*mine), None)
    bounds = np.cumsum([0] + counts)
    frequencies = {name: roots.at[start:stop] for name, start, stop in zip(names, bounds[:-1], bounds[1:])}
    for name, start, stop in zip(names, bounds[:-1], bounds[1:]):
        crossing = LEVELS[name].reveals
        if crossing:
            hidden = roots.hidden[start:stop].ravel()
            frequencies[crossing] = np.concatenate([frequencies[crossing], hidden[~np.isnan(hidden)]])
    values = _evaluated(loop, {name: frequencies[name] for name in ("G", "P", "S", "A")})
    margins: dict[str, list[Margin]] = {}
    for name in ("G", "P", "S", "A"):
        points = np.concatenate([frequencies[name], w[brackets[name].exact]])
        at = np.concatenate([values[name], gh[brackets[name].exact]])
        unique, first = np.unique(points, return_index=True)
        if loop.axis_poles.size:  # refined onto a pole of GH: not a margin
            near = np.min(np.abs(unique[:, None] / loop.axis_poles[None, :] - 1.0), axis=1) < 1e-12
            unique, first = unique[~near], first[~near]
        margins[name] = margins_of(name, unique, at[first])
    return margins, shared


@dataclass(frozen=True)
class Level:
    """A level function of GH and its slope h' (from dGH/domega).

    Magnitudes: h = log |GH + shift| (shift 0: |GH|, 1: the distance to -1),
    h' = Re(dGH / (GH + shift)).  Angles: h = the angle of GH from the
    negative real axis, continued from the bracket's left end (so it is
    continuous across the axis and 0 on it), h' = Im(dGH / GH).
    """

    shift: float
    angle: bool
    stationary: bool  # an extremum (a root of h') rather than a crossing (a root of h)
    direction: int  # of the target's sign change: +1 rising, -1 falling, 0 either
    reveals: str = ""  # extrema: the crossing of h that may hide on either side (see `_refined`)

    @property
    def watched(self) -> bool:
        return bool(self.reveals)


LEVELS = {
    "S": Level(1.0, False, True, 1),
    "A": Level(0.0, False, True, -1, "P"),
    "Amin": Level(0.0, False, True, 1, "P"),
    "phase": Level(0.0, True, True, 0, "G"),
    "G": Level(0.0, True, False, 0),
    "P": Level(0.0, False, False, 0),
}


@dataclass(frozen=True)
class Brackets:
    """Grid intervals [w[index], w[index + 1]] holding a root of one level,
    and grid points where its target is exactly 0 (``exact``)."""

    index: NDArray[np.intp]
    exact: NDArray[np.intp]


# which constant level (see `Detection.flat`) makes a bracket kind meaningless
FLAT_LEVEL = {"S": "1+GH", "A": "GH", "Amin": "GH", "P": "GH", "phase": "phase", "G": "phase"}


def _off_poles(brackets: Brackets, w: NDArray, poles: NDArray) -> Brackets:
    """Without the intervals that hold a pole of GH on the imaginary axis: a
    sign change across a pole (Im GH or |GH| - 1 jumping through infinity) is
    not a crossing."""
    lo, hi = w[brackets.index], w[brackets.index + 1]
    spans = np.any((lo[:, None] <= poles[None, :]) & (poles[None, :] <= hi[:, None]), axis=1)
    return Brackets(brackets.index[~spans], brackets.exact)


def _grid_brackets(w: NDArray, gh: NDArray, dgh: NDArray, flat: frozenset[str] = frozenset()) -> dict[str, Brackets]:
    """Per level, the intervals where its target (h' for extrema, h for
    crossings) changes sign in its direction.  Kept only where they matter:
    minima of |GH| and extrema of the phase that may hide two crossings
    (minima above 1; phase extrema short of the negative real axis), gain
    crossings on the negative real axis.  A sign change between two values
    of rounding-noise size (relative `NOISE`), an exact zero where the
    level does not move, and any root of a constant level are not roots."""
    with np.errstate(all="ignore"):
        relative, distance = dgh / gh, dgh / (1.0 + gh)
        mag = np.abs(gh)
        scale = {
            "S": np.abs(distance),
            "A": np.abs(relative),
            "Amin": np.abs(relative),
            "phase": np.abs(relative),
            "G": mag,
            "P": np.maximum(mag, 1.0),
        }
    im = np.sign(gh.imag)
    negative = (gh.real[:-1] < 0) | (gh.real[1:] < 0)
    targets = {
        "S": distance.real,
        "A": relative.real,
        "Amin": relative.real,
        "phase": relative.imag,
        "G": gh.imag,
        "P": mag - 1.0,
    }
    moving = {"G": np.abs(relative.imag) * w > NOISE, "P": np.abs(relative.real) * w > NOISE}
    keep = {"Amin": (mag[:-1] > 1) & (mag[1:] > 1), "phase": (im[:-1] == im[1:]) & negative, "G": negative}
    out = {}
    for name, level in LEVELS.items():
        if FLAT_LEVEL[name] in flat:
            out[name] = Brackets(np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp))
            continue
        target = targets[name]
        index = sign_changes(target, rising_only=level.direction > 0, falling_only=level.direction < 0)
        with np.errstate(all="ignore"):
            loud = np.abs(target) > NOISE * scale[name]
        index = index[loud[index] | loud[index + 1]]
        if name in keep:
            index = index[keep[name][index]]
        exact = np.flatnonzero(target == 0) if level.direction == 0 else np.zeros(0, dtype=np.intp)
        if name in moving:
            exact = exact[moving[name][exact]]
        if name == "G":
            exact = exact[gh.real[exact] < 0]
        out[name] = Brackets(index, exact)
    return out


def _level_values(
    g: NDArray, dg: NDArray, shift: NDArray, left: NDArray, offset: NDArray, angle: NDArray
) -> tuple[NDArray, NDArray]:
    """(h, h') of each point's own level (see `Level`): ``left`` is the
    bracket's left-end GH for angles (1 for magnitudes), ``offset`` the
    angle of that end from the negative real axis (0 for magnitudes)."""
    with np.errstate(all="ignore"):
        base = g + shift
        turned, ratio = base / left, dg / base
        magnitude = np.where(shift != 0, log_distance(g), np.log(np.abs(g)))
        h = np.where(angle, np.arctan2(turned.imag, turned.real) + offset, magnitude)
    return h, np.where(angle, ratio.imag, ratio.real)


def _refine(loop: LoopModel, lo: tuple, hi: tuple, levels: list[Level], counts: list[int]) -> Roots:
    """`refine` on brackets given by their ends' (omega, GH, dGH), ``counts[k]``
    of them on ``levels[k]``."""
    return refine(*_job(loop, lo, hi, levels, counts))


def _job(loop: LoopModel, lo: tuple, hi: tuple, levels: list[Level], counts: list[int]) -> Job:
    """`_refine`'s brackets and level function as a `Job` (to refine alone or with another search's)."""

    def each(field: str, dtype: type) -> NDArray:
        return np.repeat(np.array([getattr(level, field) for level in levels], dtype=dtype), counts)

    shift, angle = each("shift", float), each("angle", bool)
    left, offset, (ha, da), (hb, db) = _end_levels(shift, angle, lo[1:], hi[1:])

    def fun(points: NDArray, which: NDArray) -> tuple[NDArray, NDArray]:
        return _level_values(*loop.evaluate(points), shift[which], left[which], offset[which], angle[which])

    return Job(fun, lo[0], hi[0], ha, hb, da, db, each("stationary", bool), each("watched", bool))


def _end_levels(shift: NDArray, angle: NDArray, lo: tuple, hi: tuple) -> tuple:
    """From the ends' (GH, dGH): each bracket's angle reference (``left``,
    ``offset`` of `_level_values`) and (h, h') at both ends."""
    left, offset = np.where(angle, lo[0], 1.0), np.where(angle, np.angle(-lo[0]), 0.0)
    return left, offset, _level_values(*lo, shift, left, offset, angle), _level_values(*hi, shift, left, offset, angle)


def _evaluated(loop: LoopModel, frequencies: dict[str, NDArray]) -> dict[str, NDArray]:
    """GH at every level's frequencies, in one evaluation."""
    every = np.concatenate(list(frequencies.values()))
    values = loop.evaluate(every)[0] if every.size else np.zeros(0, dtype=complex)
    out, start = {}, 0
    for name, points in frequencies.items():
        out[name], start = values[start : start + points.size], start + points.size
    return out


def _grid_margins(loop: LoopModel, gain_band: Band, phase_band: Band, attenuation_above: float | None) -> Margins:
    """The CIP listing's grid rules (GAINMG, PHASEM, SRMINS) on the user's grid."""
    w, gh = loop.omega, loop.gh
    im, mag2 = gh.imag, np.abs(gh) ** 2

    def nearest(f: NDArray, i: NDArray) -> NDArray:
        return np.where(np.abs(f[i + 1]) < np.abs(f[i]), i + 1, i)

    gi = sign_changes(im)
    gi = nearest(im, gi[gh.real[gi + 1] < 0])  # GAINMG tests Re GH at the later point
    pi = nearest(mag2 - 1.0, sign_changes(mag2 - 1.0))
    dist2 = np.abs(1.0 + gh) ** 2
    si = sign_changes(np.diff(dist2), rising_only=True) + 1
    ai = sign_changes(np.diff(mag2), falling_only=True) + 1
    gi = gi[np.array([gain_band.contains(w[i]) for i in gi], dtype=bool)]
    pi = pi[np.array([phase_band.contains(w[i]) for i in pi], dtype=bool)]
    ai = ai[w[ai] > attenuation_above] if attenuation_above is not None else ai[:0]
    noise = table_noise(gh)
    found = (gi.size, pi.size, si.size)
    gi = _beyond_noise(gi, np.abs(np.angle(-gh)), noise)
    pi = _beyond_noise(pi, np.abs(np.log(np.sqrt(mag2))), noise)
    si = _deeper_than_noise(si, np.sqrt(dist2), NOISE_FLOOR * noise * np.abs(gh))
    notes = ["tabulated loop: margins at grid points (report 000 grid rule), not refined"]
    if (gi.size, pi.size, si.size) != found:
        notes.append(
            f"the table's noise is about {noise:.1g} relative (second differences of log GH): crossings within "
            f"{NOISE_FLOOR:g} times it of -180 deg or of |GH| = 1 count once, minima of |1 + GH| shallower than "
            f"it are not margins ({sum(found) - gi.size - pi.size - si.size} dropped)"
        )
    return Margins(
        gain=tuple(margins_of("G", w[gi], gh[gi])),
        phase=tuple(margins_of("P", w[pi], gh[pi])),
        stability=tuple(margins_of("S", w[si], gh[si])),
        attenuation=tuple(margins_of("A", w[ai], gh[ai])),
        method="grid",
        notes=tuple(notes),
    )


NOISE_FLOOR = 5.0  # crossings and minima within this many times the table's noise are one, or none


def table_noise(gh: NDArray[np.complex128]) -> float:
    """The table's relative noise: the median size of the second differences of log GH (log
    magnitude and unwrapped phase) over sqrt(6) (white noise's), by 0.6745 (a median's).
    Smooth data sampled coarsely read as a little noise: their curvature."""
    with np.errstate(all="ignore"):
        log_gh = np.log(np.abs(gh)) + 1j * np.unwrap(np.angle(gh))
    second = np.abs(log_gh[:-2] - 2.0 * log_gh[1:-1] + log_gh[2:])
    second = second[np.isfinite(second)]
    return float(np.median(second) / (0.6745 * np.sqrt(6.0))) if second.size else 0.0


def _beyond_noise(crossings: NDArray[np.intp], distance: NDArray, noise: float) -> NDArray[np.intp]:
    """One crossing (the middle one) of each run whose points between stay within
    `NOISE_FLOOR` noise of the threshold (``distance``: from it, relative)."""
    if crossings.size < 2 or noise == 0.0:
        return crossings
    runs, current = [], [int(crossings[0])]
    for i in crossings[1:].tolist():
        if np.max(distance[current[-1] : i + 1]) <= NOISE_FLOOR * noise:
            current.append(i)
        else:
            runs.append(current)
            current = [i]
    runs.append(current)
    return np.array([run[len(run) // 2] for run in runs], dtype=np.intp)


def _deeper_than_noise(minima: NDArray[np.intp], distance: NDArray, floor: NDArray) -> NDArray[np.intp]:
    """The minima of ``distance`` whose prominence exceeds the noise ``floor`` there."""
    if minima.size == 0:
        return minima
    return minima[valley_prominences(distance, minima) > floor[minima]]


def valley_prominences(d: NDArray, at: NDArray[np.intp] | None = None) -> NDArray:
    """Per point (of ``at``, default all), how far it lies below the lower of the highest
    points between it and the nearest lower point on either side (an edge where there is
    none): a valley's prominence, as scipy.signal.peak_prominences has it (whose import
    costs start-up)."""
    at = np.arange(d.size) if at is None else np.asarray(at, dtype=np.intp)
    return np.minimum(_rise(d, at), _rise(d[::-1], d.size - 1 - at)) - d[at]


def _rise(d: NDArray, at: NDArray[np.intp]) -> NDArray:
    """At each point of ``at``, the largest value between it and the nearest lower point to
    its left (all the points before it where none is lower; -inf where there are none).  By
    doubling, on the minima and maxima of every run of 2**k points: a point's reach left
    (the points before it none lower, a NaN lower than all) grows by the runs that fit,
    longest first; its largest value is that of two runs of 2**k covering the reach from
    both ends."""
    lows, highs = _run_extremes(d)
    reach = np.zeros(at.size, dtype=np.intp)
    for level in reversed(range(lows.shape[0])):
        start = at - reach - (1 << level)
        fits = start >= 0
        fits[fits] = lows[level, start[fits]] >= d[at[fits]]
        reach[fits] += 1 << level
    out = np.full(at.size, -np.inf)
    some = np.flatnonzero(reach)
    level, ends = np.frexp(reach[some])[1] - 1, at[some]  # floor(log2 reach), exactly
    out[some] = np.maximum(highs[level, ends - reach[some]], highs[level, ends - (1 << level)])
    return out


def _run_extremes(d: NDArray) -> tuple[NDArray, NDArray]:
    """Row k: the minimum (the maximum) of the 2**k points from each (-inf past the end),
    for every k with 2**k <= d.size."""
    lows, highs, width = [d], [d], 1
    while 2 * width <= d.size:
        lows.append(np.minimum(lows[-1][:-width], lows[-1][width:]))
        highs.append(np.maximum(highs[-1][:-width], highs[-1][width:]))
        width *= 2
    padded = np.full((2, len(lows), d.size), -np.inf)
    for k, (low, high) in enumerate(zip(lows, highs)):
        padded[0, k, : low.size], padded[1, k, : high.size] = low, high
    return padded[0], padded[1]

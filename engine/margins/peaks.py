"""Peaks of closed-loop magnitudes over frequency, refined to exact extrema.

Ms = max |S| (S = 1/(1 + GH)), Mt = max |T| (T = GH/(1 + GH)) and the peak
of |K S| in a band for a given compensator K.  `refined_peaks` is the one
refinement helper, shared with `engine.margins.disk`: a magnitude |f| of the
loop (``f`` a `Transform` of GH and dGH/domega) is searched on the margins'
detection grid (`engine.margins.detection_grid`), every interval that could hide a
maximum-minimum pair of |f| is halved (bounded: `MAX_ROUNDS`, a point
budget), every sign change of d log|f|/domega from + to - is refined to
4 ulp (`engine.numerics.refinement.refine`, all at once, vectorized) and the largest
of those maxima and the ends (w = 0, w -> inf: limits) is the peak.
Tabulated loops are searched on a rational fit of the table, as margins
are.  Method and bounds: docs/analysis.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.loop.pole_zero import ZpkEvaluator
from engine.loop.responses import Evaluator, LoopModel, SampledLoop
from engine.margins.detection_grid import detection_grid, may_hide_pair
from engine.margins.pole_zero.peaks import moebius_peaks
from engine.margins.sampled import sampled_peaks
from engine.margins.search import FIT_LIMIT, Band, Margins, fitted_loop, margins, margins_alongside
from engine.numerics.refinement import Job, Roots, refine, sign_changes

# (omega, GH, dGH/domega) -> (f, df/domega): the magnitude |f| is what a peak maximizes
Transform = Callable[[NDArray, NDArray, NDArray], tuple[NDArray, NDArray]]

MAX_ROUNDS = 40  # of halving intervals that could hide a pair of extrema of |f|
EXTRA_POINTS = 20_000  # the halving may add at most this many points to the detection grid
END_LOOKS = 8  # limits at w -> 0 and w -> inf: at most this many decades-doubling steps
AGREEMENT = 1e-11  # relative: the pole-zero form must match the network at every peak


@dataclass(frozen=True)
class Peak:
    """The largest |f| over a band, where it is (0 or inf: a limit at an end) and how it was found."""

    value: float
    frequency: float
    method: str = "refined"  # "refined", "fitted (residual ...)" or "grid"
    notes: tuple[str, ...] = field(default=())

    @property
    def db(self) -> float:
        """The peak in dB (20 log10)."""
        return float(20.0 * np.log10(self.value)) if self.value > 0 else float("-inf")


def sensitivity(w: NDArray, gh: NDArray, dgh: NDArray) -> tuple[NDArray, NDArray]:
    """S = 1/(1 + GH) and dS/domega."""
    with np.errstate(all="ignore"):
        s = 1.0 / (1.0 + gh)
        return s, -dgh * s * s


def complementary(w: NDArray, gh: NDArray, dgh: NDArray) -> tuple[NDArray, NDArray]:
    """T = GH/(1 + GH) and dT/domega."""
    with np.errstate(all="ignore"):
        s = 1.0 / (1.0 + gh)
        return np.where(np.abs(gh) > 1.0, 1.0 / (1.0 + 1.0 / gh), gh * s), dgh * s * s


# (a, b) of a transform (a + b GH)/(1 + GH): its peaks are found without a grid (`engine.margins.pole_zero.peaks`)
sensitivity.moebius = (1.0, 0.0)
complementary.moebius = (0.0, 1.0)


def compensator_sensitivity(compensator: Evaluator) -> Transform:
    """The transform K S, K and dK/domega given by ``compensator(omega)``."""

    def ks(w: NDArray, gh: NDArray, dgh: NDArray) -> tuple[NDArray, NDArray]:
        k, dk = compensator(w)
        s, ds = sensitivity(w, gh, dgh)
        return k * s, dk * s + k * ds

    return ks


def transfer_evaluator(transfer, params: dict[str, float]) -> Evaluator:
    """omega -> (K(j omega), dK/domega) of one block's transfer (e.g. the compensator)."""
    fun = transfer.compile(params)

    def evaluate(w: NDArray) -> tuple[NDArray, NDArray]:
        value, slope = fun(1j * np.asarray(w, dtype=float))
        return value, 1j * slope

    return evaluate


UNBOUNDED = 1e12  # a peak of |S|, |T| or |K S| beyond this: 1 + GH is 0 there to rounding


def unbounded_note(peak: Peak) -> str | None:
    """What a peak beyond `UNBOUNDED` means (a closed-loop pole on the imaginary axis
    there, to rounding: 1/s^2 gave 3.2e14); None for a peak within it."""
    if not peak.value > UNBOUNDED:
        return None
    return (
        f"unbounded: 1 + GH is 0 to rounding at {peak.frequency:.6g} rad/s (a closed-loop pole on the imaginary axis)"
    )


def reported(peak: Peak) -> Peak:
    """The peak as shown to a reader: beyond `UNBOUNDED`, inf with its `unbounded_note`.
    The algorithms' measures keep the finite value: their differences need one."""
    note = unbounded_note(peak)
    return peak if note is None else replace(peak, value=math.inf, notes=peak.notes + (note,))


def sensitivity_peak(loop: LoopModel, band: Band = Band()) -> Peak:
    """Ms = max |S| over ``band``, refined (`reported`)."""
    return reported(refined_peaks(loop, [sensitivity], band)[0])


def complementary_peak(loop: LoopModel, band: Band = Band()) -> Peak:
    """Mt = max |T| over ``band``, refined (`reported`)."""
    return reported(refined_peaks(loop, [complementary], band)[0])


def compensator_peak(loop: LoopModel, compensator: Evaluator, band: Band = Band()) -> Peak:
    """max |K S| over ``band`` (K from ``compensator``: omega -> (K, dK/domega)), refined (`reported`)."""
    return reported(refined_peaks(loop, [compensator_sensitivity(compensator)], band)[0])


def magnitude_curves(loop: LoopModel, omega: NDArray | None = None) -> tuple[NDArray, NDArray, NDArray]:
    """(omega, |S|, |T|) on ``omega`` (default: the loop's grid), for plots."""
    w = loop.omega if omega is None else np.asarray(omega, dtype=float)
    gh = loop.gh if omega is None else (loop.evaluate(w)[0] if loop.evaluate is not None else None)
    if gh is None:
        raise EngineError("a tabulated loop's |S| and |T| are known on its own frequencies only")
    with np.errstate(all="ignore"):
        return w, np.abs(1.0 / (1.0 + gh)), np.abs(gh / (1.0 + gh))


def refined_peaks(loop: LoopModel, transforms: Sequence[Transform], band: Band = Band()) -> tuple[Peak, ...]:
    """The peak of |f| over ``band`` for every transform f, refined together (module docstring)."""
    _check_band(band)
    if not transforms:
        return ()
    if isinstance(loop, SampledLoop):
        return sampled_peaks(loop, refined_peaks, transforms, band)
    if loop.evaluate is None:
        return _table_peaks(loop, transforms, band)
    peaks = _without_grid(loop, transforms, band)
    if peaks is not None:
        return peaks
    return _checked(loop, transforms, band, _peaks_on(loop, transforms, band))


def margins_and_peaks(
    loop: LoopModel, transforms: Sequence[Transform], attenuation_above: float | None = None
) -> tuple[Margins, tuple[Peak, ...] | EngineError]:
    """``margins(loop, attenuation_above=...)`` and ``refined_peaks(loop, transforms)``, the same numbers;
    when both search the loop's detection grid, the peaks' maxima are refined in the same vectorized
    steps as the margins' crossings and extrema (`engine.margins.search.margins_alongside`): one
    refinement of the loop, not two.  When the peaks' search fails, its `EngineError` stands in their
    place and the margins are still found once; the margins' own failure is raised."""
    if not transforms or isinstance(loop, SampledLoop) or loop.evaluate is None:
        return margins(loop, attenuation_above=attenuation_above), peaks_or_failure(
            lambda: refined_peaks(loop, transforms)
        )
    try:
        grid_free = _without_grid(loop, transforms, Band())
        search = grid_free if grid_free is not None else _peak_search(loop, transforms, Band())
    except EngineError as exc:
        return margins(loop, attenuation_above=attenuation_above), exc
    if not isinstance(search, PeakSearch):  # found without a grid
        return margins(loop, attenuation_above=attenuation_above), search
    try:
        found, roots = margins_alongside(loop, search.job, attenuation_above)
    except EngineError:  # either part: each alone (the margins' failure raised again)
        found, roots = margins(loop, attenuation_above=attenuation_above), None

    def peaks() -> tuple[Peak, ...]:
        refined = search.refined() if roots is None else roots
        return _checked(loop, transforms, Band(), _peaks_of(loop, transforms, Band(), search, refined))

    return found, peaks_or_failure(peaks)


def peaks_or_failure(peaks: Callable[[], tuple[Peak, ...]]) -> tuple[Peak, ...] | EngineError:
    """The peaks, or the `EngineError` that says why they could not be found."""
    try:
        return peaks()
    except EngineError as exc:
        return exc


def _check_band(band: Band) -> None:
    if not band.low <= band.high or band.low < 0:
        raise EngineError(f"a peak's band must be 0 <= low <= high, not {band.low!r}..{band.high!r}")


def _checked(loop: LoopModel, transforms: Sequence[Transform], band: Band, peaks: tuple[Peak, ...]) -> tuple[Peak, ...]:
    """The peaks found on the loop's fast form, or searched again on the network where that form disagrees there."""
    if loop.exact is not loop.evaluate and not fast_form_agrees(loop, transforms, peaks):
        return _peaks_on(loop.on_exact(), transforms, band)
    return peaks


def _without_grid(loop: LoopModel, transforms: Sequence[Transform], band: Band) -> tuple[Peak, ...] | None:
    """The peaks of a rational loop in pole-zero form whose transforms are all
    Moebius transforms of GH, found without a grid (`engine.margins.pole_zero.peaks`); None
    when that method does not apply (or its form disagrees with the network)."""
    pairs = [getattr(t, "moebius", None) for t in transforms]
    if not (loop.rational and isinstance(loop.evaluate, ZpkEvaluator)) or any(p is None for p in pairs):
        return None
    found = moebius_peaks(loop.evaluate, pairs, band.low, band.high)
    if found is None:
        return None
    peaks = tuple(Peak(value, frequency) for value, frequency in found)
    if not getattr(loop.evaluate, "factored", False) and not fast_form_agrees(loop, transforms, peaks):
        return None
    return peaks


def _peaks_on(loop: LoopModel, transforms: Sequence[Transform], band: Band) -> tuple[Peak, ...]:
    search = _peak_search(loop, transforms, band)
    return _peaks_of(loop, transforms, band, search, search.refined())


@dataclass(frozen=True)
class PeakSearch:
    """A grid search of peaks up to its refinement: the resolved grid ``w``, each transform's levels on it,
    the interior maxima's brackets (``job``, None when there are none) and which transform each is of."""

    w: NDArray
    levels: list[tuple[NDArray, NDArray]]
    group: NDArray
    job: Job | None
    notes: list[str]

    def refined(self) -> Roots | None:
        """The maxima refined alone."""
        return None if self.job is None else refine(*self.job)


def _peak_search(loop: LoopModel, transforms: Sequence[Transform], band: Band) -> PeakSearch:
    grid = detection_grid(loop)
    notes = list(grid.notes)
    if not loop.rational:
        notes.append(
            f"searched within {grid.omega[0]:.6g}..{grid.omega[-1]:.6g} rad/s (the plot grid's range joined with what the loop's corners and crossovers need)"
        )
    w, gh, dgh = band_grid(loop, grid.omega, grid.gh, grid.dgh, band)
    w, gh, dgh = resolved_grid(loop, transforms, w, gh, dgh, notes)
    levels = [log_level(*t(w, gh, dgh)) for t in transforms]
    job, group = maxima_job(loop, transforms, w, levels)
    return PeakSearch(w, levels, group, job, notes)


def _peaks_of(
    loop: LoopModel, transforms: Sequence[Transform], band: Band, search: PeakSearch, roots: Roots | None
) -> tuple[Peak, ...]:
    """The peaks from the refined maxima (``roots``), the grid points and the ends."""
    w, group, notes = search.w, search.group, search.notes
    at = np.zeros(0) if roots is None else roots.at
    values = _levels_at(loop, transforms, at, group)[0]
    found = [_candidates(w, search.levels[k][0], at[group == k], values[group == k]) for k in range(len(transforms))]
    ends = _ends(loop, transforms, w, band, notes) if loop.rational else [([], [])] * len(transforms)
    out = []
    for (points, values), (end_w, end_v) in zip(found, ends):
        points, values = np.concatenate([points, end_w]), np.concatenate([values, end_v])
        values = np.where(np.isfinite(values), values, -np.inf)
        best = int(np.argmax(values))
        out.append(Peak(float(np.exp(values[best])), float(points[best]), "refined", tuple(notes)))
    return tuple(out)


def log_level(f: NDArray, df: NDArray) -> tuple[NDArray, NDArray]:
    """h = log |f| and h' = d h/domega = Re(f'/f)."""
    with np.errstate(all="ignore"):
        return np.log(np.abs(f)), (df / f).real


def band_grid(loop: LoopModel, w: NDArray, gh: NDArray, dgh: NDArray, band: Band) -> tuple[NDArray, ...]:
    """The grid cut to the band, with the band's finite inner ends added (evaluated exactly)."""
    keep = (w >= band.low) & (w <= band.high)
    ends = np.array([x for x in (band.low, band.high) if 0 < x < np.inf and w[0] <= x <= w[-1]])
    w, gh, dgh = w[keep], gh[keep], dgh[keep]
    if ends.size:
        eg, edg = loop.evaluate(ends)
        w, gh, dgh = np.concatenate([w, ends]), np.concatenate([gh, eg]), np.concatenate([dgh, edg])
        w, first = np.unique(w, return_index=True)
        gh, dgh = gh[first], dgh[first]
    if w.size < 2:
        raise EngineError(f"the band {band.low:g}..{band.high:g} rad/s holds no searched frequencies")
    return w, gh, dgh


def resolved_grid(
    loop: LoopModel, transforms: Sequence[Transform], w: NDArray, gh: NDArray, dgh: NDArray, notes: list[str]
) -> tuple[NDArray, ...]:
    """The grid with every interval halved that could hide a pair of extrema of
    some |f| (the detection grid's own test, `may_hide_pair`, on f), bounded.
    The test reads an interval's ends alone: each round tests only the halves
    made by the last one (an interval left whole passed it already)."""
    budget = w.size + EXTRA_POINTS
    split = _hiding(transforms, w, gh, dgh, np.arange(w.size - 1))
    for _ in range(MAX_ROUNDS):
        if not split.any():
            return w, gh, dgh
        if w.size + np.count_nonzero(split) > budget:
            notes.append(
                f"the peak search reached its budget of {budget} points: narrow peaks near "
                f"{float(np.median(w[:-1][split])):.6g} rad/s may be missed"
            )
            return w, gh, dgh
        a, b = w[:-1][split], w[1:][split]
        mid = np.where(a > 0, np.sqrt(a * b), 0.5 * b)
        mg, mdg = loop.evaluate(mid)
        w, gh, dgh = np.concatenate([w, mid]), np.concatenate([gh, mg]), np.concatenate([dgh, mdg])
        order = np.argsort(w, kind="stable")
        w, gh, dgh = w[order], gh[order], dgh[order]
        at = np.flatnonzero(order >= w.size - mid.size)  # the middles' places: each opens two new intervals
        fresh = np.concatenate([at - 1, at])
        split = np.zeros(w.size - 1, dtype=bool)
        split[fresh] = _hiding(transforms, w, gh, dgh, fresh)
    notes.append(f"the peak search stopped after {MAX_ROUNDS} rounds of halving")
    return w, gh, dgh


def _hiding(transforms: Sequence[Transform], w: NDArray, gh: NDArray, dgh: NDArray, index: NDArray) -> NDArray:
    """Which of the intervals [w[i], w[i + 1]] (i in ``index``) could hide a pair of extrema
    of some |f| and can still be halved."""
    ends, k = np.concatenate([index, index + 1]), index.size
    values = [t(w[ends], gh[ends], dgh[ends]) for t in transforms]
    f, df = np.array([v[0] for v in values]), np.array([v[1] for v in values])  # a row per transform
    hide = _may_hide(f[:, :k], df[:, :k], f[:, k:], df[:, k:]).any(axis=0)
    return hide & ((w[index + 1] - w[index]) > 1e-12 * w[index + 1])


def _may_hide(f0: NDArray, df0: NDArray, f1: NDArray, df1: NDArray) -> NDArray[np.bool_]:
    """Intervals (ends: f and df/domega at 0 and 1) over which |f| could have a maximum and a minimum inside."""
    with np.errstate(all="ignore"):
        ratio0, ratio1 = df0 / f0, df1 / f1
        theta0, theta1 = np.arctan2(ratio0.imag, ratio0.real), np.arctan2(ratio1.imag, ratio1.real)
        turn = np.abs(np.angle(f1 / f0)) + np.abs(np.angle(df1 / df0))
        hide = may_hide_pair(theta0, theta1, turn)
    return hide & np.isfinite(turn)


def refined_maxima(
    loop: LoopModel, transforms: Sequence[Transform], w: NDArray, levels: list[tuple[NDArray, NDArray]]
) -> tuple[NDArray, NDArray]:
    """Every interior maximum of every |f| (h' from + to -), refined in one
    vectorized `refine`; their frequencies and which transform each is of."""
    job, group = maxima_job(loop, transforms, w, levels)
    return (np.zeros(0) if job is None else refine(*job).at), group


def maxima_job(
    loop: LoopModel, transforms: Sequence[Transform], w: NDArray, levels: list[tuple[NDArray, NDArray]]
) -> tuple[Job | None, NDArray]:
    """`refined_maxima`'s brackets and level function (None: no interior maximum), and which
    transform each bracket is of."""
    index = [sign_changes(d, falling_only=True) for _, d in levels]
    group = np.concatenate([np.full(i.size, k) for k, i in enumerate(index)]).astype(int)
    if group.size == 0:
        return None, group
    i = np.concatenate(index)
    h = np.concatenate([levels[k][0][j] for k, j in enumerate(index)])
    h1 = np.concatenate([levels[k][0][j + 1] for k, j in enumerate(index)])
    d = np.concatenate([levels[k][1][j] for k, j in enumerate(index)])
    d1 = np.concatenate([levels[k][1][j + 1] for k, j in enumerate(index)])

    def fun(points: NDArray, which: NDArray) -> tuple[NDArray, NDArray]:
        return _levels_at(loop, transforms, points, group[which])

    return Job(fun, w[i], w[i + 1], h, h1, d, d1, True), group


def _levels_at(loop: LoopModel, transforms: Sequence[Transform], at: NDArray, owner: NDArray) -> tuple[NDArray, ...]:
    """h = log |f| and h' at each point ``at`` of its own transform (``owner``: its number), in one evaluation
    of the loop: every transform on every point, each point's taken."""
    if at.size == 0:
        return np.zeros(0), np.zeros(0)
    g, dg = loop.evaluate(at)
    rows = [log_level(*t(at, g, dg)) for t in transforms]
    column = np.arange(at.size)
    return np.array([h for h, _ in rows])[owner, column], np.array([d for _, d in rows])[owner, column]


def _candidates(w: NDArray, h: NDArray, at: NDArray, values: NDArray) -> tuple[NDArray, NDArray]:
    """Refined maxima and every grid point (a maximum at a band end is a grid point)."""
    return np.concatenate([at, w]), np.concatenate([values, h])


def _ends(
    loop: LoopModel, transforms: Sequence[Transform], w: NDArray, band: Band, notes: list[str]
) -> list[tuple[list, list]]:
    """Per transform, the limits of log |f| at w -> 0 and w -> inf when the
    band reaches there (reported at frequencies 0 and inf)."""
    out: list[tuple[list, list]] = [([], []) for _ in transforms]
    for reach, start, factor, at in ((band.low == 0, w[0], 0.1, 0.0), (band.high == np.inf, w[-1], 10.0, np.inf)):
        if not reach:
            continue
        for k, (value, settled) in enumerate(_limit(loop, transforms, start, factor)):
            if not settled:
                notes.append(f"|f| still grows towards {at:g} rad/s: its last value is used")
            out[k][0].append(at)
            out[k][1].append(value)
    return out


def _limit(loop: LoopModel, transforms: Sequence[Transform], start: float, factor: float) -> list[tuple[float, bool]]:
    """Per transform, log |f| as omega -> 0 (factor < 1) or inf, by steps of
    factor**(2**j) (at most `END_LOOKS`), and whether it settled (changed by
    at most 4 ulp).  A level still falling there is -inf (never the peak)."""
    looks = [start * factor ** (2 ** (j + 1)) for j in range(END_LOOKS)]
    within = next((j for j, x in enumerate(looks) if not 0 < x < np.inf), len(looks))
    rows = _looked(loop, transforms, np.array(looks[:within]))
    rows, out = rows[: _first_settled(rows)], []
    for k in range(len(transforms)):
        values = rows[:, k]
        values = values[~np.isnan(values)]
        if values.size < 2:
            out.append((-np.inf, True))
        elif _settled(values[-2], values[-1]):
            out.append((float(values[-1]), True))
        else:
            out.append((-np.inf, True) if values[-1] < values[-2] else (float(values[-1]), False))
    return out


def _looked(loop: LoopModel, transforms: Sequence[Transform], x: NDArray) -> NDArray:
    """log |f| at the looks ``x``, a row per look and a column per transform, in one evaluation; the
    looks from the first whose response overflows on left out (an `EngineError`: those before are the limit)."""
    try:
        with np.errstate(all="ignore"):
            g, dg = loop.evaluate(x)
    except EngineError:
        return _looked(loop, transforms, x[:-1]) if x.size > 1 else np.zeros((0, len(transforms)))
    with np.errstate(all="ignore"):
        return np.array([log_level(*t(x, g, dg))[0] for t in transforms]).reshape(len(transforms), x.size).T


def _first_settled(rows: NDArray) -> int:
    """How many looks the sequential search takes: up to the first whose every level is within 4 ulp of the
    look before (all of them when none is)."""
    calm = np.flatnonzero(_settled(rows[:-1], rows[1:]).all(axis=1))
    return int(calm[0]) + 2 if calm.size else rows.shape[0]


def _settled(a: NDArray, b: NDArray) -> NDArray[np.bool_]:
    with np.errstate(all="ignore"):
        return (a == b) | (np.abs(b - a) <= 4e-16 * np.maximum(1.0, np.abs(b)))


def fast_form_agrees(loop: LoopModel, transforms: Sequence[Transform], peaks: Sequence[Peak]) -> bool:
    """Does the fast form of GH agree with the network at every finite interior peak?"""
    w = np.array([p.frequency for p in peaks if 0 < p.frequency < np.inf])
    if w.size == 0:
        return True
    try:
        exact, fast = loop.exact(w)[0], loop.evaluate(w)[0]
    except EngineError:
        return False
    with np.errstate(all="ignore"):
        return bool(np.all(np.abs(exact - fast) <= AGREEMENT * np.abs(exact)))


def _table_peaks(loop: LoopModel, transforms: Sequence[Transform], band: Band) -> tuple[Peak, ...]:
    """Peaks of a tabulated loop: refined on its rational fit (the margins' fit), else grid maxima."""
    fitted = fitted_loop(loop)
    if fitted is not None:
        residual = fitted.residual
        note = f"tabulated loop: peaks refined on {fitted.how} (relative residual {residual:.1e} on the table)"
        found = _peaks_on(fitted.model, transforms, band)
        return tuple(Peak(p.value, p.frequency, f"fitted (residual {residual:.1e})", (note,) + p.notes) for p in found)
    keep = (loop.omega >= band.low) & (loop.omega <= band.high)
    if not keep.any():
        raise EngineError(f"the band {band.low:g}..{band.high:g} rad/s holds no table frequencies")
    w, gh = loop.omega[keep], loop.gh[keep]
    note = f"the table could not be fitted within {FIT_LIMIT:g} relative: peaks at grid points"
    out = []
    for t in transforms:
        value = np.abs(t(w, gh, np.zeros_like(gh))[0])
        best = int(np.nanargmax(value))
        out.append(Peak(float(value[best]), float(w[best]), "grid", (note,)))
    return tuple(out)

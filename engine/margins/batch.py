"""The margins of many loops of one structure (`engine.loop.batch_forms`): the gain and
phase margins and the closed-loop stability abscissa of every sample at once
(`engine.margins.pole_zero.batch_search`), and, for a sample whose batch certificate
fails, the per-loop grid-free search on its own pole-zero form
(`engine.margins.pole_zero.search`, with its repair of single misses and its piece-by-piece
crossings).

A sample gets None, and goes to the whole per-loop path (`engine.margins.search.margins`),
when its form is odd, when that search does not apply either (a near-tangent crossing, a
degenerate level: the per-loop path takes its detection grid), or when a level is constant
(the per-loop path says what that means in its notes).  Otherwise its margins are the ones
the per-loop path finds on the same form, to rounding: the same levels polished by the same
Newton's method, GH(0) of a loop without an integrator as a gain margin at 0 when it is
negative.  The margins are kept as arrays over the samples (`BatchLoops`); a batched
sample's `Margins`, made only when asked for (`BatchLoops.loop`), hold its gain and phase
margins, and when asked its attenuation margins (the maxima of |GH| the search polished and
certified; rows that read the stability margins are not batched).  A loop in z is batched on
its w-plane form, as `engine.margins.sampled` searches it: frequencies in rad/s, the gain
margin at the Nyquist frequency, the abscissa of the closed-loop poles' s-plane equivalents
(a diagram in z's margins polished on its w-plane realizations first, in w).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from engine.loop.batch_forms import BatchForms
from engine.loop.batch_realized_forms import RealizedForms
from engine.loop.pole_zero import ZpkEvaluator
from engine.margins.peak_measures import band_delay, peak_arrays, peak_values, transform
from engine.margins.peaks import Peak
from engine.margins.pole_zero.batch_peaks import batch_moebius_peaks
from engine.margins.pole_zero.batch_search import batch_crossings
from engine.margins.pole_zero.levels import LoopLevels
from engine.margins.pole_zero.peaks import moebius_peaks
from engine.margins.pole_zero.search import fast_margins
from engine.margins.sampled import band_in_nu, in_rad_per_s
from engine.margins.search import Band
from engine.margins.values import Margin, Margins, margin_forms, margins_of, single_margin
from engine.model.bilinear import real_frequency, s_of_z, z_of_w
from engine.model.paired_product import PairedProduct


class SampleLoop(NamedTuple):
    """One sample's margins, its closed-loop stability abscissa (-max Re of the closed-loop
    poles, the zeros of 1 + GH) and whether the batch certified it (else the per-loop search
    on its form found them); its closed-loop rows are the batch's (`closed_rows`)."""

    margins: Margins
    abscissa: float
    batched: bool


ClosedRow = tuple[int, str, float, float]  # a closed-loop row: its number, measure kind, band's low and high
UNSETTLED = 1e-9  # |abscissa| within which the closed loop's stability is left to the per-loop path


class ClosedRows(NamedTuple):
    """Every sample's closed-loop rows (`closed_rows`): values and frequencies (samples, rows: the
    rows' column ``columns[number]``), ``found``: False where the per-loop path must take the sample,
    ``batched``: found by the batched peak search (else by the per-loop search on its form)."""

    values: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    columns: dict[int, int]
    found: NDArray[np.bool_]
    batched: NDArray[np.bool_]


def closed_rows(
    forms: BatchForms, loops: BatchLoops, rows: list[ClosedRow], sample_time: float | None = None
) -> ClosedRows:
    """Every sample's closed-loop rows (Ms, Mt, the disk and delay margins,
    `engine.margins.peak_measures`) over the rows' bands, as `engine.slp.peaks.closed_loop_values`
    reads them: the peaks by the batched grid-free peak search
    (`engine.margins.pole_zero.batch_peaks`), a sample it does not certify by the per-loop search
    on its batched form (`engine.margins.pole_zero.peaks.moebius_peaks`, what the per-loop path runs
    on a cascade's factored form); the delay margins from the phase margins' arrays, the closed
    loop's stability from the abscissa.  Not found: a sample the per-loop path must take, where
    neither search applies (the per-loop path's grid then) or whose abscissa is within `UNSETTLED`
    of 0.  With ``sample_time`` the forms are a loop in z's w-plane forms: the bands searched in
    nu = tan(omega T/2), the peaks' frequencies back in rad/s (`engine.margins.sampled`)."""
    count = forms.gain.size
    settled = loops.found & (np.abs(loops.abscissa) > UNSETTLED)
    stable = loops.abscissa > 0
    values, frequencies = np.full((count, len(rows)), np.nan), np.full((count, len(rows)), np.nan)
    peaks = [row for row in rows if row[1] != "delay_margin"]
    kinds = sorted({kind for _, kind, _, _ in peaks})
    pairs = [getattr(transform(kind), "moebius", None) for kind in kinds]
    found = batch_moebius_peaks(forms, pairs, settled) if None not in pairs else None
    batched = settled & (found is not None and found.certified)
    for column, (_, kind, low, high) in enumerate(rows):
        if kind == "delay_margin":
            values[:, column], frequencies[:, column] = _band_delays(loops, low, high, stable)
        elif found is not None:
            value, at, sure = found.peak(kinds.index(kind), *_searched_band(low, high, sample_time))
            batched &= sure
            at = at if sample_time is None else real_frequency(at, sample_time)
            values[:, column], frequencies[:, column] = peak_arrays(kind, value, at, stable)
    columns = {row[0]: column for column, row in enumerate(rows)}
    done = batched | ~settled
    for k in np.flatnonzero(~done).tolist():
        loop = loops.loop(k)
        one = None if loop is None else _closed_rows(forms, k, loop, rows, bool(stable[k]), sample_time)
        if one is None:
            settled[k] = False
            continue
        for number, (value, frequency) in one.items():
            values[k, columns[number]], frequencies[k, columns[number]] = value, frequency
    return ClosedRows(values, frequencies, columns, settled, batched)


def _band_delays(loops: BatchLoops, low: float, high: float, stable: NDArray) -> tuple[NDArray, NDArray]:
    """Every sample's smallest delay margin of the gain crossovers in [low, high] and its frequency
    (`engine.margins.peak_measures.band_delay` over the phase margins' arrays)."""
    w = loops.phase
    with np.errstate(invalid="ignore"):
        delay = margin_forms("P", w, loops.phase_gh)["delay"]
        delay = np.where((w > 0) & (w >= low) & (w <= high) & ~np.isnan(delay), delay, np.inf)
    first = np.argmin(delay, axis=1)[:, None] if w.shape[1] else np.zeros((w.shape[0], 1), dtype=int)
    padded = np.concatenate([delay, np.full((w.shape[0], 1), np.inf)], axis=1)
    value = np.take_along_axis(padded, first, 1)[:, 0]
    at = np.where(np.isfinite(value), np.take_along_axis(np.pad(w, ((0, 0), (0, 1))), first, 1)[:, 0], np.nan)
    return np.where(stable, value, 0.0), np.where(stable, at, np.nan)


def _searched_band(low: float, high: float, sample_time: float | None) -> tuple[float, float]:
    """A band in rad/s as the peak search reads it: in nu = tan(omega T/2) for a loop in z."""
    if sample_time is None:
        return low, high
    band = band_in_nu(Band(low, high), sample_time)
    return band.low, band.high


def _closed_rows(
    forms: BatchForms, k: int, loop: SampleLoop, rows: list[ClosedRow], stable: bool, sample_time: float | None
) -> dict[int, tuple[float, float]] | None:
    """Sample ``k``'s closed-loop rows by the per-loop search on its form, band by band as
    `engine.slp.peaks.closed_loop_values` reads them."""
    form = ZpkEvaluator(complex(float(forms.gain[k]), 0.0), forms.zeros[k], forms.poles[k], factored=True)
    out: dict[int, tuple[float, float]] = {}
    bands: dict[tuple[float, float], list[tuple[int, str]]] = {}
    for number, kind, low, high in rows:
        if kind == "delay_margin":
            out[number] = band_delay(loop.margins, Band(low, high), stable)
        else:
            bands.setdefault((low, high), []).append((number, kind))
    for (low, high), band_rows in bands.items():
        kinds = [kind for _, kind in band_rows]
        pairs = [getattr(transform(kind), "moebius", None) for kind in kinds]
        found = None if None in pairs else moebius_peaks(form, pairs, *_searched_band(low, high, sample_time))
        if found is None:
            return None
        if sample_time is not None:
            found = [(value, float(real_frequency(nu, sample_time))) for value, nu in found]
        values = peak_values(kinds, [Peak(value, frequency) for value, frequency in found], stable)
        for (number, _), (value, frequency, _) in zip(band_rows, values):
            out[number] = (value, frequency)
    return out


@dataclass(frozen=True)
class BatchLoops:
    """Every sample's margins as arrays (samples, margins): the gain, phase and (when asked)
    attenuation margins' frequencies (rad/s) and GH at them, in the order the per-loop path lists
    them, NaN-padded; the closed-loop stability abscissa; ``found``: False where the per-loop
    path must take the sample; ``batched``: certified by the batch (else the per-loop search on
    its form found it: its record in ``searched``, whose margins `loop` reads from the arrays,
    polished there with ``exact``).  No Python object is made per certified sample (`loop`
    makes one)."""

    gain: NDArray[np.float64]
    gain_gh: NDArray[np.complex128]
    phase: NDArray[np.float64]
    phase_gh: NDArray[np.complex128]
    peaks: NDArray[np.float64]
    peaks_gh: NDArray[np.complex128]
    abscissa: NDArray[np.float64]
    found: NDArray[np.bool_]
    batched: NDArray[np.bool_]
    searched: dict[int, SampleLoop]

    def loop(self, k: int) -> SampleLoop | None:
        """Sample ``k``'s margins as `Margins` (None where the per-loop path must take it)."""
        if not self.found[k]:
            return None
        gain = _margins_in("G", self.gain[k], self.gain_gh[k])
        phase = _margins_in("P", self.phase[k], self.phase_gh[k])
        peaks = _margins_in("A", self.peaks[k], self.peaks_gh[k])
        abscissa = float(self.abscissa[k])
        own = self.searched.get(k)
        if own is not None:  # the per-loop search's record, its margins as the arrays hold them (polished)
            margins = replace(own.margins, gain=gain, phase=phase, attenuation=peaks)
            return own._replace(margins=margins, abscissa=abscissa)
        return SampleLoop(Margins(gain, phase, (), peaks, method="refined"), abscissa, True)


def _margins_in(kind: str, w: NDArray, gh: NDArray) -> tuple[Margin, ...]:
    """One padded row's margins of one kind (the NaN padding left out)."""
    there = np.isfinite(w)
    return tuple(margins_of(kind, w[there], gh[there]))


def batch_margins(
    forms: BatchForms, sample_time: float | None = None, attenuation: bool = False
) -> list[SampleLoop | None]:
    """Every sample's margins as `Margins` (`batch_loops`, one sample at a time); None for a
    sample the per-loop path must take."""
    loops = batch_loops(forms, sample_time, attenuation)
    return [loops.loop(k) for k in range(forms.gain.size)]


def batch_loops(
    forms: BatchForms, sample_time: float | None = None, attenuation: bool = False, exact: RealizedForms | None = None
) -> BatchLoops:
    """Every sample's margins as arrays (module docstring).  With ``sample_time`` the forms are a
    loop in z's w-plane forms (`engine.margins.sampled`): frequencies come back in rad/s, a gain
    margin at the Nyquist frequency where GH(-1) is real and negative, the abscissa of the
    closed-loop poles' s-plane equivalents.  With ``attenuation`` the margins hold the
    attenuation margins too (the maxima of |GH|, the modal peaks' rows): a sample with one that
    stopped in the rounding noise, not within 4 ulp, is not certified (the per-loop search may
    stop elsewhere in the noise).  With ``exact`` (the forms are realizations' minimal forms,
    `engine.loop.batch_realized_forms`) every margin found is polished on the realization's own
    GH (`polished`), as the per-loop path polishes a form that is not exact to rounding on the
    network, and the abscissa is that of the closed realizations' eigenvalues and hidden poles
    (`RealizedForms.closed`, the per-loop stability row's matrices; the form's closed-loop roots and
    the hidden poles for a singular algebraic loop)."""
    found = batch_crossings(forms, polished=exact is not None)
    gain, gain_gh = _with_dc(found.phase, found.phase_gh, _dc_values(forms))
    phase, phase_gh = found.gain, found.gain_gh
    peaks, peaks_gh = (found.peaks, found.peaks_gh) if attenuation else _none(forms.gain.size)
    abscissa = _abscissa(found.closed, sample_time) if sample_time is not None else found.abscissa
    certified = found.certified & (found.peaks_converged | (not attenuation)) & ~forms.odd
    own = {}  # the per-loop search's loops on their forms (w-plane frequencies for a loop in z)
    for k in np.flatnonzero(~certified & ~forms.odd).tolist():
        loop = sample_loop(forms, k, sample_time)
        if loop is not None:
            own[k] = loop
    gain, gain_gh = _with_searched(gain, gain_gh, own, "gain")
    phase, phase_gh = _with_searched(phase, phase_gh, own, "phase")
    peaks, peaks_gh = _with_searched(peaks, peaks_gh, own, "attenuation")
    abscissa = abscissa.copy()
    abscissa[list(own)] = [loop.abscissa for loop in own.values()]
    found_mask = certified.copy()
    found_mask[list(own)] = True
    if exact is not None:  # (a loop in z's on its w-plane realizations, before its frequencies go to rad/s)
        gain, gain_gh, far = polished(exact, gain, gain_gh, 4)
        phase, phase_gh, far_phase = polished(exact, phase, phase_gh, 3)
        peaks, peaks_gh, far_peaks = polished(exact, peaks, peaks_gh, 0)
        found_mask &= ~(far | far_phase | far_peaks)
        of_forms = np.minimum(abscissa, _abscissa(exact.hidden, sample_time))
        abscissa = of_forms if exact.closed is None else _abscissa(exact.closed, sample_time)
    if sample_time is not None:
        gain, phase, peaks = (real_frequency(w, sample_time) for w in (gain, phase, peaks))
        gain, gain_gh = _with_nyquist(gain, gain_gh, forms, sample_time)
    searched = {k: _in_time(loop, forms, k, sample_time) for k, loop in own.items()}
    return BatchLoops(gain, gain_gh, phase, phase_gh, peaks, peaks_gh, abscissa, found_mask, certified, searched)


POLISH_REACH = 1e-8  # relative: a margin the form placed further from the realization's is not polished (per loop)


def polished(exact: RealizedForms, w: NDArray, gh: NDArray, level: int) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
    """Margins found on the minimal forms polished by one Newton step on the realizations' GH
    (`RealizedForms.response`), GH there, and the samples with a margin the step moved by more
    than `POLISH_REACH` (the form is off there: the per-loop path takes them).  The form agrees
    with the realization to about 1e-11, so the step's error is about its square: the step uses
    the realization's value and the form's derivative (its error scales the step only), and GH
    at the new point is the realization's GH plus its slope times the step (an error of the
    step's square).  ``level`` 4: the crossings of the negative real axis (Im GH = 0), 3 the gain
    crossovers (log|GH| = 0), 0 the maxima of |GH| (d log|GH|/domega = 0, its slope the
    realization's).  A margin at 0 (GH(0)) stays."""
    with np.errstate(invalid="ignore"):
        samples, column = np.nonzero(w > 0)
    at = w[samples, column]
    form = PairedProduct(exact.forms.gain, exact.forms.zeros, exact.forms.poles)
    terms = form.terms(1j * at, curvature=level == 0, samples=samples)
    value, slope = exact.response(samples, at, slope=level == 0)
    with np.errstate(all="ignore"):
        if level == 4:  # d Im GH / domega = Re(GH u), u = d log GH / ds
            step = value.imag / (terms.value * terms.slope).real
        elif level == 3:  # d log|GH| / domega = -Im u
            step = np.log(np.abs(value)) / -terms.slope.imag
        else:  # d log|GH| / domega = Re(GH' / GH), its derivative -Re du/ds
            step = (slope / value).real / -terms.curvature.real
        moved = value - step * (slope if slope is not None else 1j * terms.value * terms.slope)
    far = np.zeros(w.shape[0], dtype=bool)
    far[samples[~(np.abs(step) <= POLISH_REACH * at)]] = True
    w, gh = w.copy(), gh.copy()
    w[samples, column], gh[samples, column] = at - step, moved
    return w, gh, far


def _with_searched(w: NDArray, gh: NDArray, searched: dict[int, SampleLoop], family: str) -> tuple[NDArray, NDArray]:
    """The arrays of one family of margins (a `Margins` field) with the searched samples' rows in
    place of the batch's (NaN columns added where they hold more)."""
    width = max((len(getattr(loop.margins, family)) for loop in searched.values()), default=0)
    extra = max(0, width - w.shape[1])
    if extra:
        w = np.pad(w, ((0, 0), (0, extra)), constant_values=np.nan)
        gh = np.pad(gh, ((0, 0), (0, extra)), constant_values=np.nan)
    for k, loop in searched.items():
        margins = getattr(loop.margins, family)
        w[k], gh[k] = np.nan, np.nan
        w[k, : len(margins)] = [m.frequency for m in margins]
        gh[k, : len(margins)] = [m.gh for m in margins]
    return w, gh


def _none(count: int) -> tuple[NDArray, NDArray]:
    """No margins of a kind for ``count`` samples."""
    return np.zeros((count, 0)), np.zeros((count, 0), dtype=complex)


def _abscissa(closed: NDArray, sample_time: float | None) -> NDArray:
    """-max Re of the closed-loop poles (rows); with ``sample_time``, poles in w: of their
    s-plane equivalents s = ln(z)/T, z = (1 + w)/(1 - w)."""
    with np.errstate(all="ignore"):
        s = closed if sample_time is None else s_of_z(z_of_w(closed), sample_time)
        return -np.max(s.real, axis=1, initial=-np.inf)


def _in_time(loop: SampleLoop, forms: BatchForms, k: int, sample_time: float | None) -> SampleLoop:
    """A w-plane sample's margins in rad/s with the Nyquist frequency's gain margin, as
    `engine.margins.sampled.sampled_margins` makes them (the loop itself for an s loop)."""
    if sample_time is None:
        return loop
    margins = in_rad_per_s(loop.margins, sample_time)
    if forms.zeros.shape[1] == forms.poles.shape[1] and forms.gain[k] < 0:
        nyquist = single_margin("G", math.pi / sample_time, complex(float(forms.gain[k]), 0.0))
        if not any(abs(m.frequency - nyquist.frequency) <= 1e-9 * nyquist.frequency for m in margins.gain):
            margins = replace(margins, gain=margins.gain + (nyquist,))
    return SampleLoop(margins, loop.abscissa, loop.batched)


def _with_nyquist(w: NDArray, gh: NDArray, forms: BatchForms, sample_time: float) -> tuple[NDArray, NDArray]:
    """The gain margins (rad/s) with the Nyquist frequency's last where GH(-1), GH's limit as w
    grows, is real and negative (as many zeros as poles, a negative gain) and no margin is there
    already (`_in_time` for one sample)."""
    nyquist = math.pi / sample_time
    with np.errstate(invalid="ignore"):
        there = (np.abs(w - nyquist) <= 1e-9 * nyquist).any(axis=1)
    added = (forms.zeros.shape[1] == forms.poles.shape[1]) & (forms.gain < 0) & ~there
    column = np.where(added, nyquist, np.nan)[:, None]
    return _compact(np.concatenate([w, column], axis=1), np.concatenate([gh, forms.gain[:, None] + 0j], axis=1))


def _with_dc(w: NDArray, gh: NDArray, dc: NDArray) -> tuple[NDArray, NDArray]:
    """The gain margins with GH(0) first where it is finite and negative (a loop without an
    integrator whose DC gain is on the negative real axis), then the others above 0, as the
    per-loop path lists them (all of them where GH(0) is not such)."""
    negative = np.isfinite(dc) & (dc.real < 0)
    with np.errstate(invalid="ignore"):
        kept = np.where(negative[:, None] & ~(w > 0), np.nan, w)
    column = np.where(negative, 0.0, np.nan)[:, None]
    return _compact(np.concatenate([column, kept], axis=1), np.concatenate([(dc.real + 0j)[:, None], gh], axis=1))


def _compact(w: NDArray, gh: NDArray) -> tuple[NDArray, NDArray]:
    """Each row's entries in their order, NaN ones last, the columns no row fills dropped."""
    order = np.argsort(np.isnan(w), axis=1, kind="stable")
    width = int(np.isfinite(w).sum(axis=1).max(initial=0))
    return np.take_along_axis(w, order, 1)[:, :width], np.take_along_axis(gh, order, 1)[:, :width]


def _dc_values(forms: BatchForms) -> NDArray[np.complex128]:
    """GH(0) of every sample (real; not finite with an integrator)."""
    return PairedProduct(forms.gain, forms.zeros, forms.poles).terms(np.zeros(forms.gain.size)).value


def sample_loop(forms: BatchForms, k: int, sample_time: float | None = None) -> SampleLoop | None:
    """Sample ``k``'s margins and abscissa by the per-loop search on its form, or None (with
    ``sample_time``: a w-plane form, its abscissa the s-plane equivalents')."""
    form = ZpkEvaluator(complex(float(forms.gain[k]), 0.0), forms.zeros[k], forms.poles[k], factored=True)
    frequencies = fast_margins(form)
    levels = LoopLevels.of(form)
    if frequencies is None or levels is None or levels.constant:
        return None
    every = np.concatenate(list(frequencies.values()))
    values = form(every)[0] if every.size else np.zeros(0, dtype=complex)
    found, start = {}, 0
    for name, points in frequencies.items():
        found[name], start = margins_of(name, points, values[start : start + points.size]), start + points.size
    with np.errstate(all="ignore"):
        dc = form(np.zeros(1))[0][0]
    crossings = [m for m in found["G"] if m.gh.real < 0]
    w, gh = _with_dc(
        np.array([m.frequency for m in crossings]).reshape(1, -1),
        np.array([m.gh for m in crossings], dtype=complex).reshape(1, -1),
        np.array([dc]),
    )
    gain = tuple(margins_of("G", w[0], gh[0]))
    margins = Margins(gain, tuple(found["P"]), tuple(found["S"]), tuple(found["A"]), method="refined")
    if sample_time is not None:
        abscissa = float(_abscissa(levels.closed[None, :], sample_time)[0])
    else:
        abscissa = float(-np.max(levels.closed.real)) if levels.closed.size else math.inf
    return SampleLoop(margins, abscissa, False)

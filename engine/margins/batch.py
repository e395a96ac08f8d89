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
negative.  A batched sample's `Margins` hold its gain and phase margins, and when asked its
attenuation margins (the maxima of |GH| the search polished and certified; rows that read
the stability margins are not batched).  A loop in z is batched on its
w-plane form, as `engine.margins.sampled` searches it: frequencies in rad/s, the gain
margin at the Nyquist frequency, the abscissa of the closed-loop poles' s-plane equivalents.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from engine.loop.batch_forms import BatchForms
from engine.loop.pole_zero import ZpkEvaluator
from engine.margins.peak_measures import band_delay, peak_values, transform
from engine.margins.peaks import Peak
from engine.margins.pole_zero.batch_search import batch_crossings
from engine.margins.pole_zero.levels import LoopLevels
from engine.margins.pole_zero.peaks import moebius_peaks
from engine.margins.pole_zero.search import fast_margins
from engine.margins.sampled import in_rad_per_s
from engine.margins.search import Band
from engine.margins.values import Margin, Margins, margins_of, single_margin
from engine.model.bilinear import s_of_z, z_of_w
from engine.model.paired_product import PairedProduct


class SampleLoop(NamedTuple):
    """One sample's margins, its closed-loop stability abscissa (-max Re of the closed-loop
    poles, the zeros of 1 + GH) and whether the batch certified it (else the per-loop search
    on its form found them); ``closed``: its closed-loop rows (`with_closed_rows`), by row."""

    margins: Margins
    abscissa: float
    batched: bool
    closed: Mapping[int, tuple[float, float]] | None = None


ClosedRow = tuple[int, str, float, float]  # a closed-loop row: its number, measure kind, band's low and high
UNSETTLED = 1e-9  # |abscissa| within which the closed loop's stability is left to the per-loop path


def with_closed_rows(
    forms: BatchForms, loops: list[SampleLoop | None], rows: list[ClosedRow]
) -> list[SampleLoop | None]:
    """The samples' loops with their closed-loop rows (Ms, Mt, the disk and delay margins,
    `engine.margins.peak_measures`) over the rows' bands: the peaks by the per-loop grid-free
    peak search on each sample's batched form (`engine.margins.pole_zero.peaks.moebius_peaks`,
    what the per-loop path runs on a cascade's factored form), the delay margins from the
    sample's phase margins, the closed loop's stability from its abscissa.  None for a sample
    where that search does not apply (the per-loop path's grid then) or whose abscissa is
    within `UNSETTLED` of 0."""
    out: list[SampleLoop | None] = []
    for k, loop in enumerate(loops):
        if loop is None or abs(loop.abscissa) <= UNSETTLED:
            out.append(None)
            continue
        found = _closed_rows(forms, k, loop, rows, loop.abscissa > 0)
        out.append(None if found is None else loop._replace(batched=False, closed=found))
    return out


def _closed_rows(
    forms: BatchForms, k: int, loop: SampleLoop, rows: list[ClosedRow], stable: bool
) -> dict[int, tuple[float, float]] | None:
    """Sample ``k``'s closed-loop rows, band by band as `engine.slp.peaks.closed_loop_values` reads them."""
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
        found = None if None in pairs else moebius_peaks(form, pairs, low, high)
        if found is None:
            return None
        values = peak_values(kinds, [Peak(value, frequency) for value, frequency in found], stable)
        for (number, _), (value, frequency, _) in zip(band_rows, values):
            out[number] = (value, frequency)
    return out


def batch_margins(
    forms: BatchForms, sample_time: float | None = None, attenuation: bool = False
) -> list[SampleLoop | None]:
    """Every sample's margins; None for a sample the per-loop path must take (module docstring).
    With ``sample_time`` the forms are a loop in z's w-plane forms (`engine.margins.sampled`):
    frequencies come back in rad/s, a gain margin at the Nyquist frequency where GH(-1) is
    real and negative, the abscissa of the closed-loop poles' s-plane equivalents.  With
    ``attenuation`` the margins hold the attenuation margins too (the maxima of |GH|, the
    modal peaks' rows): a sample with one that stopped in the rounding noise, not within 4
    ulp, is not certified (the per-loop search may stop elsewhere in the noise)."""
    found = batch_crossings(forms)
    dc = _dc_values(forms)
    gain = _per_sample("G", found.phase, found.phase_gh)
    phase = _per_sample("P", found.gain, found.gain_gh)
    peaks = _per_sample("A", found.peaks, found.peaks_gh) if attenuation else [[]] * forms.gain.size
    odd = forms.odd.tolist()
    certified = (found.certified & (found.peaks_converged | (not attenuation))).tolist()
    abscissa = (found.abscissa if sample_time is None else _sampled_abscissa(found.closed, sample_time)).tolist()
    out: list[SampleLoop | None] = []
    for k in range(forms.gain.size):
        if odd[k]:
            out.append(None)
        elif certified[k]:
            margins = Margins(_with_dc(gain[k], dc[k]), tuple(phase[k]), (), tuple(peaks[k]), method="refined")
            out.append(_in_time(SampleLoop(margins, abscissa[k], True), forms, k, sample_time))
        else:
            loop = sample_loop(forms, k, sample_time)
            out.append(None if loop is None else _in_time(loop, forms, k, sample_time))
    return out


def _sampled_abscissa(closed: NDArray, sample_time: float) -> NDArray:
    """-max Re s of the closed-loop poles in w (rows), s = ln(z)/T, z = (1 + w)/(1 - w)."""
    with np.errstate(all="ignore"):
        return -np.max(s_of_z(z_of_w(closed), sample_time).real, axis=1, initial=-np.inf)


def _in_time(loop: SampleLoop, forms: BatchForms, k: int, sample_time: float | None) -> SampleLoop:
    """A w-plane sample's margins in rad/s with the Nyquist frequency's gain margin, as
    `engine.margins.sampled.sampled_margins` makes them (the loop itself for an s loop).  GH(-1)
    is GH's limit as w grows: the gain where as many zeros as poles, else 0 or infinite."""
    if sample_time is None:
        return loop
    margins = in_rad_per_s(loop.margins, sample_time)
    if forms.zeros.shape[1] == forms.poles.shape[1] and forms.gain[k] < 0:
        nyquist = single_margin("G", math.pi / sample_time, complex(float(forms.gain[k]), 0.0))
        if not any(abs(m.frequency - nyquist.frequency) <= 1e-9 * nyquist.frequency for m in margins.gain):
            margins = replace(margins, gain=margins.gain + (nyquist,))
    return SampleLoop(margins, loop.abscissa, loop.batched)


def _per_sample(kind: str, w: NDArray, gh: NDArray) -> list[list[Margin]]:
    """Each row's margins of one kind at its frequencies (NaN padding left out), made in one call."""
    found = np.isfinite(w)
    every = margins_of(kind, w[found], gh[found])
    ends = np.concatenate([[0], np.cumsum(found.sum(axis=1))]).tolist()
    return [every[ends[k] : ends[k + 1]] for k in range(w.shape[0])]


def _with_dc(gain: list[Margin], dc: complex | None) -> tuple[Margin, ...]:
    """The gain margins with GH(0) first when it is finite and negative (a loop without an
    integrator whose DC gain is on the negative real axis), as the per-loop path lists them."""
    if dc is not None and dc.real < 0:
        return (single_margin("G", 0.0, dc), *(m for m in gain if m.frequency > 0))
    return tuple(gain)


def _dc_values(forms: BatchForms) -> list[complex | None]:
    """GH(0) of every sample, real; None where it is not finite (an integrator)."""
    value = PairedProduct(forms.gain, forms.zeros, forms.poles).terms(np.zeros(forms.gain.size)).value
    finite = np.isfinite(value).tolist()
    return [complex(v, 0.0) if ok else None for v, ok in zip(value.real.tolist(), finite)]


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
    gain = _with_dc([m for m in found["G"] if m.gh.real < 0], complex(dc.real, 0.0) if np.isfinite(dc) else None)
    margins = Margins(gain, tuple(found["P"]), tuple(found["S"]), tuple(found["A"]), method="refined")
    if sample_time is not None:
        abscissa = float(_sampled_abscissa(levels.closed[None, :], sample_time)[0])
    else:
        abscissa = float(-np.max(levels.closed.real)) if levels.closed.size else math.inf
    return SampleLoop(margins, abscissa, False)

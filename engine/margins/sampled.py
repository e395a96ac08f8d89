"""Margins and peaks of a loop in z (`engine.loop.responses.SampledLoop`): searched on its
w-plane form, where z = (1 + w)/(1 - w) makes it rational in w and the unit circle
z = exp(j omega T) is the imaginary axis w = j nu, nu = tan(omega T/2) (report 003's
unscaled w-plane), so the grid-free search of s loops and its certificate serve it
unchanged.  Bands go in as nu, every frequency comes back in rad/s, omega = (2/T) atan(nu)
exactly, up to the Nyquist frequency pi/T (nu = inf, z = -1: a gain margin there when
GH(-1) is real and negative); a delay margin is the phase margin over omega (s)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from engine.loop.responses import LoopModel, SampledLoop
from engine.margins.values import Band, Margin, Margins, single_margin
from engine.model.bilinear import real_frequency

NYQUIST_NU = 1e150  # nu this large is z = -1 to rounding: GH there is its limit


def nu_of(omega: float, sample_time: float) -> float:
    """The w-plane frequency of ``omega`` rad/s (inf at or above the Nyquist frequency)."""
    return math.inf if omega >= math.pi / sample_time else math.tan(omega * sample_time / 2.0)


def omega_of(nu: float, sample_time: float) -> float:
    """rad/s of the w-plane frequency ``nu`` (pi/T for nu = inf: `engine.model.bilinear.real_frequency`)."""
    return float(real_frequency(nu, sample_time))


def band_in_nu(band: Band, sample_time: float) -> Band:
    return Band(nu_of(band.low, sample_time), nu_of(band.high, sample_time))


def sampled_margins(
    loop: SampledLoop,
    search: Callable[..., Margins],
    gain_band: Band,
    phase_band: Band,
    attenuation_above: float | None,
    method: str,
) -> Margins:
    """``search`` (`engine.margins.search.margins`) on the loop's w-plane form, in rad/s."""
    T = loop.sample_time
    above = None if attenuation_above is None else nu_of(attenuation_above, T)
    found = search(loop.w_plane, band_in_nu(gain_band, T), band_in_nu(phase_band, T), above, method)
    converted = in_rad_per_s(found, T)
    at_nyquist = nyquist_crossing(loop.w_plane, T)
    if at_nyquist is not None and gain_band.contains(at_nyquist.frequency):
        if not any(abs(m.frequency - at_nyquist.frequency) <= 1e-9 * at_nyquist.frequency for m in converted.gain):
            converted = replace(converted, gain=converted.gain + (at_nyquist,))
    return converted


def nyquist_crossing(w_plane: LoopModel, sample_time: float) -> Margin | None:
    """The gain margin at the Nyquist frequency, where z = -1 and GH is real: a phase crossing when
    GH(-1) < 0 (the w-plane search ends short of nu = inf).  GH(-1) is GH's limit as nu grows: read
    at two values of nu (`NYQUIST_NU` and its square root), it stands where they agree; a loop
    that falls off there (GH(-1) = 0: Tustin's map of a strictly proper block) has no margin."""
    if w_plane.evaluate is None:
        return None
    with np.errstate(all="ignore"):
        value, nearer = w_plane.evaluate(np.array([NYQUIST_NU, math.sqrt(NYQUIST_NU)]))[0].tolist()
    if not (np.isfinite(value) and value.real < 0 and abs(value.imag) <= 1e-9 * abs(value)):
        return None
    if not abs(value - nearer) <= 1e-6 * abs(nearer):
        return None  # no finite nonzero limit: GH(-1) = 0
    return single_margin("G", math.pi / sample_time, complex(value.real, 0.0))


def in_rad_per_s(found: Margins, sample_time: float) -> Margins:
    """w-plane margins with their frequencies in rad/s and delay margins in seconds."""
    T = sample_time

    def margin(m: Margin) -> Margin:
        w = omega_of(m.frequency, T)
        if m.kind != "P" or m.phase_deg is None:
            return replace(m, frequency=w)
        delay = math.radians(m.phase_deg) % (2 * math.pi) / w if w > 0 else None
        return replace(m, frequency=w, delay=delay)

    return replace(
        found,
        gain=tuple(map(margin, found.gain)),
        phase=tuple(map(margin, found.phase)),
        stability=tuple(map(margin, found.stability)),
        attenuation=tuple(map(margin, found.attenuation)),
        crossovers_beyond=None if found.crossovers_beyond is None else omega_of(found.crossovers_beyond, T),
        notes=found.notes + (f"a loop in z, T = {T:g} s: searched on its w-plane form, frequencies up to pi/T",),
    )


def sampled_peaks(loop: SampledLoop, search: Callable[..., Sequence], transforms: Sequence, band: Band) -> tuple:
    """``search`` (`engine.margins.peaks.refined_peaks`) on the w-plane form, in rad/s."""
    found = search(loop.w_plane, transforms, band_in_nu(band, loop.sample_time))
    return tuple(replace(p, frequency=omega_of(p.frequency, loop.sample_time)) for p in found)

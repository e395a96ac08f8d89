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
negative.  A batched sample's `Margins` hold its gain and phase margins only (rows that read
the stability or attenuation margins are not batched).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from engine.loop.batch_forms import BatchForms
from engine.loop.pole_zero import ZpkEvaluator
from engine.margins.pole_zero.batch_search import batch_crossings
from engine.margins.pole_zero.levels import LoopLevels
from engine.margins.pole_zero.search import fast_margins
from engine.margins.values import Margin, Margins, margins_of, single_margin
from engine.model.paired_product import PairedProduct


class SampleLoop(NamedTuple):
    """One sample's margins, its closed-loop stability abscissa (-max Re of the closed-loop
    poles, the zeros of 1 + GH) and whether the batch certified it (else the per-loop search
    on its form found them)."""

    margins: Margins
    abscissa: float
    batched: bool


def batch_margins(forms: BatchForms) -> list[SampleLoop | None]:
    """Every sample's margins; None for a sample the per-loop path must take (module docstring)."""
    found = batch_crossings(forms)
    dc = _dc_values(forms)
    gain = _per_sample("G", found.phase, found.phase_gh)
    phase = _per_sample("P", found.gain, found.gain_gh)
    odd, certified, abscissa = forms.odd.tolist(), found.certified.tolist(), found.abscissa.tolist()
    out: list[SampleLoop | None] = []
    for k in range(forms.gain.size):
        if odd[k]:
            out.append(None)
        elif certified[k]:
            margins = Margins(_with_dc(gain[k], dc[k]), tuple(phase[k]), (), (), method="refined")
            out.append(SampleLoop(margins, abscissa[k], True))
        else:
            out.append(sample_loop(forms, k))
    return out


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


def sample_loop(forms: BatchForms, k: int) -> SampleLoop | None:
    """Sample ``k``'s margins and abscissa by the per-loop search on its form, or None."""
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
    margins = Margins(gain, tuple(found["P"]), tuple(found["S"]), (), method="refined")
    abscissa = float(-np.max(levels.closed.real)) if levels.closed.size else math.inf
    return SampleLoop(margins, abscissa, False)

"""Peaks of closed-loop magnitudes of many loops of one structure at once (`engine.loop.batch_forms`):
the method of `engine.margins.pole_zero.peaks` (Ms, Mt, the disk margin's |S - 1/2|: f = (a + b
GH)/(1 + GH)) with a leading axis of samples, as `engine.margins.pole_zero.batch_search` vectorizes
the margins' search.

For each sample and transform: the stationary points of |f| are the real positive zeros, in x =
omega^2, of sum_c' 1/(x + c'^2) - sum_c 1/(x + c^2) (c' the roots of a D + b k N, c the closed-loop
poles), found by one batched eigenvalue call on the stacked companion matrices and polished by
Newton's method on the exact pole-zero form (`batch_search.batch_newton`: the per-loop search's
steps and stopping rule, through the iteration driver).  The certificate is the per-loop one
without its repair: the slope of log|f| has the sign the stationary points predict at every check
point (`batch_search.check_points`), and the values at the first and last stationary points are
consistent with |f|'s limits at 0 and infinity.  A sample whose roots cannot be had, whose sum
vanishes (a constant |f|) or that fails a check is not ``certified``, nor is a peak at (or within
rounding of) a maximum that stopped in the rounding noise rather than within 4 ulp (the per-loop
search may stop elsewhere in it): the per-loop search on its form takes it.  The peak over a band is the largest |f| at the maxima inside
it, at its finite ends and at the limits it reaches, as the per-loop search takes it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.loop.batch_forms import BatchForms
from engine.margins.pole_zero.batch_search import (
    BatchLevels,
    aligned_sum,
    batch_newton,
    batch_roots,
    check_points,
    closed_loop_poles,
    distinct_rows,
    fraction_zeros,
    leave_one_out,
    placeholders,
    reach_limits,
    real_positive,
    signs_agree,
)
from engine.margins.pole_zero.levels import ROUNDING
from engine.margins.pole_zero.peaks import Moebius, moebius, moebius_noise, moebius_slopes

TIE = 1e-12  # relative: a maximum within this of the peak could be the per-loop search's peak


@dataclass(frozen=True)
class BatchPeaks:
    """Per transform, every sample's maxima of |f| (S, m: sorted, NaN-padded), which of them stopped
    in the rounding noise (``noisy``) and |f|'s limits at 0 and at infinity (S each); which samples
    are ``certified`` (the others' numbers mean nothing)."""

    levels: BatchLevels
    transforms: tuple[Moebius, ...]
    maxima: tuple[NDArray[np.float64], ...]
    noisy: tuple[NDArray[np.bool_], ...]
    limits: tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...]
    certified: NDArray[np.bool_]

    def peak(self, number: int, low: float, high: float) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
        """Every sample's (max |f| over [low, high], where: 0 or inf for a limit at an end) for
        transform ``number``, the largest of the maxima inside, the finite ends and the limits
        reached (a tie taken at the higher frequency, as the per-loop search's `max` takes it), and
        whether it is sure: not at, nor within `TIE` of, a maximum that stopped in the rounding
        noise (the per-loop search may stop elsewhere in it: its frequency is not the batch's)."""
        ab, maxima = self.transforms[number], self.maxima[number]
        count = maxima.shape[0]
        ends = np.array([w for w in (low, high) if 0 < w < math.inf])
        with np.errstate(invalid="ignore"):
            inside = np.where((maxima >= low) & (maxima <= high), maxima, np.nan)
        noisy = np.concatenate([self.noisy[number], np.zeros((count, ends.size + 2), dtype=bool)], axis=1)
        points = np.concatenate([inside, np.tile(ends, (count, 1))], axis=1)
        with np.errstate(all="ignore"):
            values = np.abs(moebius(ab, self.levels.terms(points)[0]))
        zero, top = self.limits[number]
        for reach, at, limit in ((low == 0.0, 0.0, zero), (high == math.inf, math.inf, top)):
            if reach:
                points = np.concatenate([points, np.full((count, 1), at)], axis=1)
                values = np.concatenate([values, limit[:, None]], axis=1)
        values = np.where(np.isnan(values), -np.inf, values)
        best = values.max(axis=1, initial=-np.inf)
        where = np.where(values == best[:, None], points, -np.inf).max(axis=1, initial=-np.inf)
        near = values >= (best - TIE * np.abs(best))[:, None]
        return best, where, ~(near & noisy[:, : values.shape[1]]).any(axis=1)


def batch_moebius_peaks(forms: BatchForms, transforms: Sequence[Moebius], eligible: NDArray[np.bool_]) -> BatchPeaks:
    """Every sample's maxima of |f| for every transform, certified or not (module docstring);
    ``eligible``: the samples to certify at all (the others are not)."""
    forms = placeholders(forms)
    levels = BatchLevels(forms)
    ok = eligible & ~forms.odd & (forms.zeros.shape[1] <= forms.poles.shape[1])
    closed = closed_loop_poles(levels)
    ok &= np.isfinite(closed).all(axis=1)
    maxima, noisy, limits = [], [], []
    with np.errstate(all="ignore"):
        for ab in transforms:
            w, top, stalled, fine = _stationary(levels, ab, closed)
            zero, infinity = _limits(levels, ab)
            values = np.log(np.abs(moebius(ab, levels.terms(w)[0])))
            ok &= fine & reach_limits(w, values, top, np.log(zero), np.log(infinity))
            maxima.append(np.where(top, w, np.nan))
            noisy.append(stalled & top)
            limits.append((zero, infinity))
    return BatchPeaks(levels, tuple(transforms), tuple(maxima), tuple(noisy), tuple(limits), ok)


def _stationary(
    levels: BatchLevels, ab: Moebius, closed: NDArray
) -> tuple[NDArray, NDArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """Every sample's stationary points of |f| (S, P: sorted, NaN-padded), which are maxima, which
    stopped in the rounding noise, and whether they are certified (module docstring)."""
    scale = levels.scale[:, None]
    top_roots = _numerator_roots(levels, ab)
    roots = np.concatenate([top_roots, closed], axis=1) / scale
    t = -(roots**2)
    weights = np.concatenate([np.ones(top_roots.shape), -np.ones(closed.shape)], axis=1).astype(complex)
    x, flat = fraction_zeros(t, weights, leave_one_out(t))
    real, close = real_positive(x)
    starts = np.where(real, np.sqrt(x.real), np.nan) * scale
    near = np.where(close, np.sqrt(np.abs(x.real)), np.nan) * scale
    w, second, stalled = batch_newton(lambda at, samples: _slopes(levels, ab, at, samples), starts)
    stalled = distinct_rows(w, stalled.astype(float))[1] == 1.0  # the same order as the points'
    w, second = distinct_rows(w, second)
    fine = np.isfinite(top_roots).all(axis=1) & ~flat & ~(second == 0).any(axis=1)
    probes = check_points(levels, [w], near)
    first, noise = _slopes_and_noise(levels, ab, probes)
    return w, second < 0, stalled, fine & signs_agree(probes, first, noise, w, second < 0)


def _numerator_roots(levels: BatchLevels, ab: Moebius) -> NDArray:
    """The roots of a D + b k N of every sample (NaN rows where they cannot be had): the poles
    (b = 0), the zeros (a = 0), else from the scaled polynomials by batched eigenvalues."""
    a, b = ab
    m = levels.zero_count
    if b == 0:
        return levels.roots[:, m:]
    if a == 0:
        return levels.roots[:, :m]
    numerator, denominator = levels.scaled
    factor = (levels.gain * levels.scale ** (numerator.shape[1] - denominator.shape[1]))[:, None]
    roots, bad = batch_roots(aligned_sum(a * denominator, b * factor * numerator))
    return np.where(bad[:, None], np.nan, roots * levels.scale[:, None])


def _slopes(levels: BatchLevels, ab: Moebius, w: NDArray, samples: NDArray[np.intp]) -> tuple[NDArray, NDArray]:
    """d log|f|/domega and its derivative at the points ``w``, point k sample ``samples[k]``'s."""
    terms = levels.product.terms(1j * w, curvature=True, samples=samples)
    return moebius_slopes(ab, terms.value, terms.slope, terms.curvature)


def _slopes_and_noise(levels: BatchLevels, ab: Moebius, w: NDArray) -> tuple[NDArray, NDArray]:
    """d log|f|/domega at the finite entries of ``w`` (S, Q) and its rounding (NaN elsewhere)."""
    at = np.isfinite(w)
    terms = levels.product.terms(1j * w[at], curvature=True, size=True, samples=np.nonzero(at)[0])
    first, noise = np.full(w.shape, np.nan), np.full(w.shape, np.nan)
    first[at] = moebius_slopes(ab, terms.value, terms.slope, terms.curvature)[0]
    u_noise = ROUNDING * (terms.size + levels.roots.shape[1] * np.abs(terms.slope))
    noise[at] = moebius_noise(ab, terms.value, u_noise)
    return first, noise


def _limits(levels: BatchLevels, ab: Moebius) -> tuple[NDArray, NDArray]:
    """|f| as omega -> 0 and as omega -> infinity of every sample: GH tends to 0 (|a|), infinity
    (|b|) or a real number (GH(0), the gain)."""
    a, b = ab
    mag0, mag_inf, _, _ = levels.limits
    dc = levels.product.terms(np.zeros(levels.gain.size)).value
    out = []
    for level, gh in ((mag0, dc), (mag_inf, levels.gain + 0j)):
        value = np.abs(moebius(ab, np.where(np.isfinite(level), gh, 0.0)))
        out.append(np.where(level == np.inf, abs(b), np.where(level == -np.inf, abs(a), value)))
    return out[0], out[1]

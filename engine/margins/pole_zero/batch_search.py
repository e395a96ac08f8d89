"""The gain crossovers and the crossings of the negative real axis of many loops of
one structure at once (`engine.loop.batch_forms`), vectorized over the samples: the
method of `engine.margins.pole_zero.search` for the levels log |GH| and arg GH, every
array carrying a leading axis of samples (NaN where a sample has fewer points).

For each sample: the stationary points of log |GH| and of arg GH are the real positive
roots, in x = omega^2, of the numerators of their slopes' sums of simple fractions
(sum sigma / (x + r^2) and sum sigma r / (x + r^2)), found by one batched eigenvalue
call on the stacked companion matrices (the variable scaled by the roots' geometric
mean) and polished by Newton's method on the exact pole-zero form; the crossings
start from the roots of the same two polynomials as the per-loop search and are
polished alike.  The certificate is the per-loop one without its repair: the slopes'
signs at the check points (every root's frequency, a ladder two points a decade from
1e-3 of the smallest root to 1e3 times the largest and the unit-gain asymptotes,
around and between the stationary points, near-real eigenvalues) agree with the
stationary points found, each level reaches its limits at 0 and infinity, and the
crossings polished are as many as the monotone pieces between stationary points hold.
A sample that fails any check is not ``certified``: it goes to the per-loop search.
The closed-loop poles (the roots of D + k N) come from a batched eigenvalue call too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from engine.loop.batch_forms import BatchForms
from engine.margins.pole_zero.certificate import CLEARANCE, DUPLICATE, LIMIT_SLACK
from engine.margins.pole_zero.crossings import LIMIT_NOISE
from engine.margins.pole_zero.levels import MAX_ROOTS, PROBE_DECADES, ROUNDING, UNDAMPED, UNIT_GAIN_REACH
from engine.margins.pole_zero.search import NEAR_REAL, NEWTON_STEPS, REAL
from engine.model.paired_product import PairedProduct
from engine.numerics.bracketing import EPS, NOISE_STEP
from engine.numerics.iteration import Status, Work, iterate

NEGLIGIBLE = 1e-12  # relative to its terms, a coefficient of a sum of fractions that is 0 but for rounding
LARGEST_LOG = 300.0  # a scaled gain whose square would overflow: the per-loop search
# relative change of GH a crossing's rounding may make, at most (else the per-loop search): a
# quarter of the 1e-12 the batch equals the per-loop path to.  The bound is the worst case (8 ulp
# per root, all one way); 1e-13 refused every sample of a plant with a zeta = 0.02 mode at
# 50 rad/s (1.2e-13 at its phase crossing at 155 rad/s), whose margins equal the per-loop
# path's to 1.4e-13 at worst over 1440 light-mode samples with 2.5e-13
CONDITION = 2.5e-13


@dataclass(frozen=True)
class BatchCrossings:
    """Per sample (rows): the gain crossovers (|GH| = 1) and the crossings of the negative real
    axis, sorted and NaN-padded, GH at each, the closed-loop stability abscissa, and whether
    the sample is ``certified`` (else its values mean nothing: the per-loop search takes it)."""

    gain: NDArray[np.float64]
    gain_gh: NDArray[np.complex128]
    phase: NDArray[np.float64]
    phase_gh: NDArray[np.complex128]
    abscissa: NDArray[np.float64]
    certified: NDArray[np.bool_]
    closed: NDArray[np.complex128]  # the closed-loop poles (S, n), NaN rows where they cannot be had
    peaks: NDArray[np.float64]  # the maxima of |GH| (the attenuation margins), sorted and NaN-padded
    peaks_gh: NDArray[np.complex128]
    peaks_converged: NDArray[np.bool_]  # every stationary point of |GH| converged within 4 ulp (not stalled)


class BatchLevels:
    """The levels of every sample's loop at frequencies (S, P): GH, u = d log GH / ds and du/ds."""

    def __init__(self, forms: BatchForms):
        self.gain = forms.gain
        self.product = PairedProduct(forms.gain, forms.zeros, forms.poles)
        self.roots = np.concatenate([forms.zeros, forms.poles], axis=1)
        self.zero_count = forms.zeros.shape[1]
        self.signs = np.concatenate([np.ones(forms.zeros.shape[1]), -np.ones(forms.poles.shape[1])])
        size = np.abs(self.roots)
        nonzero = np.where(size > 0, size, np.nan)
        self.low, self.high = np.nanmin(nonzero, axis=1, initial=np.inf), np.nanmax(nonzero, axis=1, initial=0.0)
        none = ~np.isfinite(self.low)
        self.low, self.high = np.where(none, 1.0, self.low), np.where(none, 1.0, self.high)
        self.scale = np.sqrt(self.low * self.high)
        right = self.roots.real > 0
        self.phase_offset = np.where(self.gain < 0, math.pi, 0.0) + math.pi * (right * self.signs).sum(axis=1)
        self.phase_turn = np.where(right, -self.signs, self.signs)

    def terms(self, w: NDArray) -> tuple[NDArray, NDArray]:
        """GH and u at s = j w (S, P) (`engine.model.paired_product`), computed at the finite
        entries of ``w`` only (NaN elsewhere: rows are padded)."""
        at = np.isfinite(w)
        terms = self.product.terms(1j * w[at], samples=np.nonzero(at)[0])
        gh, u = np.full(w.shape, np.nan, dtype=complex), np.full(w.shape, np.nan, dtype=complex)
        gh[at], u[at] = terms.value, terms.slope
        return gh, u

    def row(self, w: NDArray, samples: NDArray[np.intp], kind: int) -> tuple[NDArray, NDArray]:
        """Newton's (first, second) for the slopes of log|GH| (0) and arg GH (1), and the
        levels log|GH| (3) and Im GH (4) (the rows of `LoopLevels.slopes`), at the points ``w``
        (1-D), point k sample ``samples[k]``'s."""
        terms = self.product.terms(1j * w, curvature=kind < 2, samples=samples)
        gh, u, du = terms.value, terms.slope, terms.curvature
        if du is not None:
            return (-u.imag, -du.real) if kind == 0 else (u.real, -du.imag)
        if kind == 3:
            return np.log(np.abs(gh)), -u.imag
        return gh.imag, (gh * u).real

    def slopes_and_noise(self, w: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """The slopes of log|GH| and arg GH at ``w`` and their rounding (`LoopLevels.slope_noise`),
        at the finite entries of ``w`` (the check points)."""
        at = np.isfinite(w)
        terms = self.product.terms(1j * w[at], size=True, samples=np.nonzero(at)[0])
        u = terms.slope
        out = np.full((3, *w.shape), np.nan)
        out[0][at], out[1][at] = -u.imag, u.real
        out[2][at] = ROUNDING * (terms.size + self.roots.shape[1] * np.abs(u))
        return out[0], out[1], out[2]

    def phase(self, w: NDArray) -> NDArray:
        """arg GH(j w), continuous in w > 0 (`LoopLevels.phase`)."""
        angles = np.arctan2(w[:, :, None] - self.roots.imag[:, None, :], np.abs(self.roots.real)[:, None, :])
        return self.phase_offset[:, None] + np.einsum("spn,sn->sp", angles, self.phase_turn)

    @cached_property
    def scaled(self) -> tuple[NDArray, NDArray]:
        """The monic polynomials (real, descending) of the zeros and of the poles, the variable
        scaled by `scale`: what the crossings' starts and the closed-loop poles are made of."""
        m, scale = self.zero_count, self.scale[:, None]
        return poly_rows(self.roots[:, :m] / scale).real, poly_rows(self.roots[:, m:] / scale).real

    @cached_property
    def limits(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """log|GH| and arg GH as omega -> 0 and -> infinity (`LoopLevels.limits`)."""
        at_zero = self.roots == 0
        n0, excess = (self.signs * at_zero).sum(axis=1), float(self.signs.sum())
        logs = np.log(np.where(at_zero, 1.0, np.abs(self.roots)))
        low_level = np.log(np.abs(self.gain)) + logs @ self.signs
        mag0 = np.where(n0 > 0, -np.inf, np.where(n0 < 0, np.inf, low_level))
        top = excess * np.inf if excess else None
        mag_inf = np.full(self.gain.size, top) if top is not None else np.log(np.abs(self.gain))
        phase0 = self.phase(np.zeros((self.gain.size, 1)))[:, 0] + math.pi / 2 * n0
        phase_inf = np.where(self.gain < 0, math.pi, 0.0) + math.pi / 2 * excess
        return mag0, mag_inf, phase0, phase_inf

    def probes(self) -> NDArray:
        """Check points (S, Q): every nonzero root's frequency and the ladder (`LoopLevels.probes`)."""
        mag0, _, _, _ = self.limits
        at_zero = self.roots == 0
        n0, excess = (self.signs * at_zero).sum(axis=1), float(self.signs.sum())
        reach = [self.low, self.high]
        with np.errstate(all="ignore"):
            logs = [np.where(n0 != 0, -mag0 / np.where(n0 == 0, 1.0, n0), np.nan)]
            if excess:
                logs.append(-np.log(np.abs(self.gain)) / excess)
        for x in logs:
            ok = np.isfinite(x) & (np.abs(x) < 700.0)
            w = np.clip(np.exp(np.where(ok, x, 0.0)), self.low / UNIT_GAIN_REACH, self.high * UNIT_GAIN_REACH)
            reach.append(np.where(ok, w, np.nan))
        low, high = np.nanmin(np.array(reach), axis=0), np.nanmax(np.array(reach), axis=0)
        decades = np.ceil(np.log10(high) - np.log10(low)) + 2 * PROBE_DECADES
        steps = np.arange(2 * int(decades.max()) + 1)
        ladder = low[:, None] * 10.0 ** (steps[None, :] / 2 - PROBE_DECADES)
        ladder = np.where(steps[None, :] <= 2 * decades[:, None], ladder, np.nan)
        return np.concatenate([np.where(at_zero, np.nan, np.abs(self.roots)), ladder], axis=1)


def batch_crossings(forms: BatchForms, polished: bool = False) -> BatchCrossings:
    """Every sample's crossings, certified or not (module docstring).  ``polished``: the crossings
    will be polished on the loops' own GH (`engine.margins.batch.polished`), so one that stopped
    in the form's rounding noise rather than within 4 ulp is certified all the same (the form's
    noise does not reach the margin; `CONDITION` still bounds the exact level's)."""
    forms = placeholders(forms)
    levels = BatchLevels(forms)
    odd = forms.odd | (levels.roots.shape[1] > MAX_ROOTS) | _on_axis(levels.roots) | (levels.gain == 0)
    with np.errstate(all="ignore"):
        t = -(levels.roots**2) / (levels.scale**2)[:, None]
        stationary, near, bad, others = [], [], odd.copy(), leave_one_out(t)
        for weights in (levels.signs[None, :] + 0 * t, levels.signs[None, :] * levels.roots / levels.scale[:, None]):
            x, flat = fraction_zeros(t, weights, others)
            real, close = real_positive(x)
            stationary.append(np.where(real, np.sqrt(x.real), np.nan) * levels.scale[:, None])
            near.append(np.where(close, np.sqrt(np.abs(x.real)), np.nan) * levels.scale[:, None])
            bad |= flat
        gains, phases, far = _crossing_starts(levels)
        points, maxima, noisy = [], [], []
        for kind, starts in enumerate(stationary):
            w, second, stalled = _newton(levels, starts, kind)
            w, second = distinct_rows(w, second)
            points.append(w)
            maxima.append(second < 0)
            noisy.append(stalled)
            bad |= (second == 0).any(axis=1)
        bad |= far | ~_signs_agree(levels, points, maxima, np.concatenate(near, axis=1))
        stationary_gh = levels.terms(points[0])[0]  # GH at the stationary points of |GH|
        at_points = [np.log(np.abs(stationary_gh)), levels.phase(points[1])]
        bad |= ~_reach_limits(levels, points, maxima, at_points)
        crossings, values, enclosed = _crossings(levels, at_points, gains, phases, polished)
        bad |= ~enclosed
        closed = closed_loop_poles(levels)
        abscissa = -np.max(closed.real, axis=1, initial=-np.inf)
        certified = ~bad & np.isfinite(abscissa)
        top = maxima[0]
        peaks, peaks_gh = distinct_rows(np.where(top, points[0], np.nan), np.where(top, stationary_gh, np.nan))
    gain, phase = crossings
    return BatchCrossings(gain, values[0], phase, values[1], abscissa, certified, closed, peaks, peaks_gh, ~noisy[0])


def placeholders(forms: BatchForms) -> BatchForms:
    """The forms with an odd sample's numbers (its roots may be infinite: a sum whose leading
    coefficient vanishes in it alone) replaced by a stable loop's, so that the arrays the search
    makes stay finite; the sample stays odd (its values mean nothing)."""
    if not forms.odd.any():
        return forms
    odd = forms.odd[:, None]
    return BatchForms(
        np.where(forms.odd, 1.0, forms.gain),
        np.where(odd, -1.0 + 0j, forms.zeros),
        np.where(odd, -2.0 + 0j, forms.poles),
        forms.odd,
    )


def _on_axis(roots: NDArray) -> NDArray[np.bool_]:
    """Samples with a root on the imaginary axis but at 0, or not finite (`LoopLevels.of` refuses them)."""
    size = np.abs(roots)
    return (~np.isfinite(size) | ((size > 0) & (np.abs(roots.real) <= UNDAMPED * size))).any(axis=1)


def poly_rows(roots: NDArray) -> NDArray[np.complex128]:
    """The monic polynomial (descending powers) of every row's roots."""
    count, n = roots.shape
    c = np.zeros((count, n + 1), dtype=complex)
    c[:, 0] = 1.0
    for k in range(n):
        c[:, 1 : k + 2] -= roots[:, k : k + 1] * c[:, : k + 1]  # (the right side is formed first)
    return c


def aligned_sum(a: NDArray, b: NDArray) -> NDArray:
    """a + b, polynomials in descending powers aligned at the constant term."""
    if a.shape[1] < b.shape[1]:
        a, b = b, a
    out = a.copy()
    out[:, a.shape[1] - b.shape[1] :] += b
    return out


def batch_roots(c: NDArray) -> tuple[NDArray[np.complex128], NDArray[np.bool_]]:
    """The roots of every row (descending real coefficients, equal degree): the companion
    matrices' eigenvalues in one call; and the rows whose leading coefficient vanishes or
    whose companion is not finite (their roots are NaN)."""
    count, n = c.shape[0], c.shape[1] - 1
    if n <= 0:
        return np.zeros((count, 0), dtype=complex), np.zeros(count, dtype=bool)
    lead = c[:, 0]
    row = -c[:, 1:] / np.where(lead == 0, 1.0, lead)[:, None]
    bad = (lead == 0) | ~np.isfinite(row).all(axis=1)
    companion = np.zeros((count, n, n))
    companion[:, 1:, :-1] = np.eye(n - 1)
    companion[:, 0, :] = np.where(bad[:, None], 0.0, row)
    roots = np.linalg.eigvals(companion).astype(complex)
    return np.where(bad[:, None], np.nan, roots), bad


def fraction_zeros(t: NDArray, weights: NDArray, others: NDArray) -> tuple[NDArray, NDArray[np.bool_]]:
    """The zeros in x of sum w_i / (x - t_i) per row (the roots of its numerator; ``others``:
    `leave_one_out` of ``t``), and the rows where the sum vanishes identically (a constant level)
    or its roots cannot be had.  Leading coefficients within `NEGLIGIBLE` of their terms in every
    row are dropped: a structure's sum can lose degrees whatever its numbers (the peaks' sums over
    the closed-loop poles and D's or N's roots, whose first moments agree when the relative degree
    is high), where the rounding would leave an exact 0 in some rows (no roots) and a spurious
    root beyond reach in others."""
    n = t.shape[1]
    numerator = np.zeros((t.shape[0], n), dtype=complex)
    sizes = np.zeros((t.shape[0], n))
    for i in range(n):
        part = weights[:, i : i + 1] * others[i].T
        numerator += part
        sizes = np.maximum(sizes, np.abs(part))
    c = numerator.real
    flat = np.abs(c).max(axis=1, initial=0.0) <= NEGLIGIBLE * sizes.max(axis=1, initial=0.0)
    while c.shape[1] > 1 and (np.abs(c[:, 0]) <= NEGLIGIBLE * sizes[:, 0]).all():
        c, sizes = c[:, 1:], sizes[:, 1:]
    x, bad = batch_roots(c)
    return x, flat | bad


def leave_one_out(t: NDArray) -> NDArray[np.complex128]:
    """(n, n, S), samples last (contiguous: the products run over them): [i, :, s] is `poly_rows`
    of t[s] without t[s, i], bit for bit (the same products in the same order), every one made at
    once: the polynomial of the roots before i is shared (the prefix), then each later root is
    applied to every polynomial that has passed its own."""
    count, n = t.shape
    roots = np.ascontiguousarray(t.T)
    out = np.zeros((n, n, count), dtype=complex)
    prefix = np.zeros((n, count), dtype=complex)
    prefix[0] = 1.0
    for k in range(n):
        out[k, : k + 1] = prefix[: k + 1]
        if k:
            out[:k, 1 : k + 1] -= roots[k] * out[:k, :k]
        if k < n - 1:
            prefix[1 : k + 2] -= roots[k] * prefix[: k + 1]
    return out


def real_positive(x: NDArray) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Which eigenvalues x = omega^2 are real and positive (Newton's starts), and which only
    near it (check points), as `engine.margins.pole_zero.search.real_eigenvalues` judges."""
    positive = x.real > 0
    real = positive & (np.abs(x.imag) <= REAL * np.abs(x))
    return real, positive & ~real & (np.abs(x.imag) <= NEAR_REAL * np.abs(x))


def _crossing_starts(levels: BatchLevels) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
    """Starts of the gain crossovers and the phase crossings (the roots of the per-loop search's two
    polynomials, `engine.margins.pole_zero.crossings.crossing_candidates`), and the samples whose
    scaled gain is beyond the range."""
    m, scale = levels.zero_count, levels.scale[:, None]
    zeros, poles = levels.roots[:, :m] / scale, levels.roots[:, m:] / scale
    log_gain = np.log(np.abs(levels.gain)) + (zeros.shape[1] - poles.shape[1]) * np.log(levels.scale)
    far = ~(np.abs(log_gain) < LARGEST_LOG)
    factor = np.exp(2 * np.where(far, 0.0, log_gain))[:, None]
    difference = aligned_sum(poly_rows(-(poles**2)).real, -factor * poly_rows(-(zeros**2)).real)
    numerator, den = levels.scaled
    mirrored = den * (-1.0) ** np.arange(den.shape[1] - 1, -1, -1)
    product = np.zeros((den.shape[0], den.shape[1] + numerator.shape[1] - 1))
    for i in range(numerator.shape[1]):
        product[:, i : i + den.shape[1]] += numerator[:, i : i + 1] * mirrored
    ascending = product[:, ::-1]
    odd = ascending[:, 1::2] * (-1.0) ** np.arange(ascending[:, 1::2].shape[1])
    out = []
    for c in (difference, odd[:, ::-1]):
        x, bad = batch_roots(c)
        keep = (x.real > 0) & (np.abs(x.imag) <= 1e-2 * np.abs(x))
        out.append(np.where(keep, np.sqrt(np.abs(x.real)), np.nan) * scale)
        far |= bad
    return out[0], out[1], far


def _newton(levels: BatchLevels, w: NDArray, kind: int) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
    """`batch_newton` on row ``kind`` of `BatchLevels.row`, the samples with a point that stalled."""
    points, second, noisy = batch_newton(lambda at, samples: levels.row(at, samples, kind), w)
    return points, second, noisy.any(axis=1)


# (points, each point's sample) -> (a level's first, its derivative): Newton's step is first / derivative
Row = Callable[[NDArray, NDArray[np.intp]], tuple[NDArray, NDArray]]


def batch_newton(row: Row, w: NDArray) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
    """Newton's method on ``row`` from every start (S, P), stopped as the per-loop search stops
    (`engine.margins.pole_zero.search.newton`), through the iteration driver: the points
    converged (NaN where not), the second derivatives there, and the points that stopped on
    rounding noise rather than within 4 ulp (STALLED: an ill-conditioned point, where the per-loop
    search may stop elsewhere in the noise).  A step that leaves w > 0 or is not finite would be
    the same step again: FAILED."""
    points, second = np.full(w.size, np.nan), np.full(w.size, np.nan)
    noisy = np.zeros(w.size, dtype=bool)
    start = np.flatnonzero(np.isfinite(w.ravel()))
    work = {"index": start, "w": w.ravel()[start], "status": np.zeros(start.size, dtype=np.int8)}
    work |= {"previous": np.full(start.size, np.inf), "second": np.zeros(start.size)}

    def advance(work: Work) -> Work:
        first, bend = row(work["w"], work["index"] // max(w.shape[1], 1))
        step = first / bend
        size, moved = np.abs(step), work["w"] - step
        exact = size <= 4 * EPS * work["w"]
        noise = ~exact & (size <= NOISE_STEP * work["w"]) & (size >= 0.5 * work["previous"])
        lost = ~(np.isfinite(moved) & (moved > 0))
        status = np.where(exact, Status.CONVERGED, np.where(noise, Status.STALLED, Status.RUNNING))
        status = np.where(lost, Status.FAILED, status).astype(np.int8)
        return work | {"w": np.where(lost, work["w"], moved), "status": status, "previous": size, "second": bend}

    def finish(work: Work, which: NDArray[np.bool_], status: NDArray[np.int8]) -> None:
        index = work["index"][which]
        found = (status == Status.CONVERGED) | (status == Status.STALLED)
        points[index[found]], second[index[found]] = work["w"][which][found], work["second"][which][found]
        noisy[index] = status == Status.STALLED

    with np.errstate(all="ignore"):
        iterate(work, lambda work: work["status"], advance, finish, NEWTON_STEPS)
    shape = w.shape
    return points.reshape(shape), second.reshape(shape), noisy.reshape(shape)


def distinct_rows(w: NDArray, second: NDArray) -> tuple[NDArray, NDArray]:
    """Every row's points sorted (NaN last), two that met merged."""
    order = np.argsort(w, axis=1)
    w, second = np.take_along_axis(w, order, 1), np.take_along_axis(second, order, 1)
    same = np.zeros(w.shape, dtype=bool)
    same[:, 1:] = np.diff(w, axis=1) <= DUPLICATE * w[:, 1:]
    w, second = np.where(same, np.nan, w), np.where(same, np.nan, second)
    order = np.argsort(w, axis=1)
    width = int(np.isfinite(w).sum(axis=1).max(initial=0))  # the columns some row fills
    return np.take_along_axis(w, order, 1)[:, :width], np.take_along_axis(second, order, 1)[:, :width]


def _signs_agree(levels: BatchLevels, points: list[NDArray], maxima: list[NDArray], near: NDArray) -> NDArray:
    """Per sample: do the slopes of log|GH| and arg GH at the check points have the signs their
    stationary points predict (`engine.margins.pole_zero.certificate`, without its repair)?"""
    probes = check_points(levels, points, near)
    *slopes, noise = levels.slopes_and_noise(probes)
    agree = np.ones(probes.shape[0], dtype=bool)
    for w, top, first in zip(points, maxima, slopes):
        agree &= signs_agree(probes, first, noise, w, top)
    return agree


def check_points(levels: BatchLevels, points: list[NDArray], near: NDArray) -> NDArray:
    """The certificate's check points (S, Q), NaN-padded: every root's frequency, the ladder, the
    near-real eigenvalues (``near``), between and around the stationary points (``points``), those
    within `CLEARANCE` of a stationary point left out (NaN)."""
    parts = [levels.probes(), near]
    for w in points:
        if w.shape[1]:
            parts += [np.sqrt(w[:, 1:] * w[:, :-1]), w[:, :1] / 4, last_column(w) * 4]
    probes = np.concatenate(parts, axis=1)
    every = np.concatenate(points, axis=1)
    if every.shape[1]:
        gap = np.abs(probes[:, :, None] / every[:, None, :] - 1.0)
        clear = np.where(np.isnan(gap), np.inf, gap).min(axis=2) > CLEARANCE
        probes = np.where(clear, probes, np.nan)
    return probes


def signs_agree(probes: NDArray, first: NDArray, noise: NDArray, w: NDArray, top: NDArray) -> NDArray[np.bool_]:
    """Per sample: does a level's slope (``first``, its rounding ``noise``) at the check points
    (``probes``) have the sign its stationary points ``w`` (maxima: ``top``) predict?  A slope
    within its rounding has no sign; one that is not finite at a check point fails."""
    known = np.isfinite(probes) & (np.abs(first) > noise)
    agree = ~(np.isfinite(probes) & np.isnan(first)).any(axis=1)
    after = np.where(top, -1.0, 1.0)
    at = np.concatenate([np.where(np.isfinite(w), w, np.inf), np.where(known, probes, np.inf)], axis=1)
    left = np.concatenate([-after, np.sign(first)], axis=1)
    right = np.concatenate([after, np.sign(first)], axis=1)
    order = np.argsort(at, axis=1, kind="stable")
    at, left, right = (np.take_along_axis(a, order, 1) for a in (at, left, right))
    both = np.isfinite(at[:, :-1]) & np.isfinite(at[:, 1:])
    return agree & ~(both & (right[:, :-1] != left[:, 1:])).any(axis=1)


def last_column(w: NDArray) -> NDArray:
    """Each row's last point (rows sorted, NaN last; NaN for a row without one), as a column."""
    count = np.isfinite(w).sum(axis=1)
    return np.where(count > 0, np.take_along_axis(w, np.maximum(count - 1, 0)[:, None], 1)[:, 0], np.nan)[:, None]


def near_limit(a: NDArray, b: NDArray) -> NDArray[np.bool_]:
    return (
        np.isfinite(a)
        & np.isfinite(b)
        & (np.abs(a - b) <= LIMIT_SLACK * np.maximum(1.0, np.maximum(np.abs(a), np.abs(b))))
    )


def _reach_limits(
    levels: BatchLevels, points: list[NDArray], maxima: list[NDArray], at_points: list[NDArray]
) -> NDArray[np.bool_]:
    """Per sample: are both levels' values at their stationary points (``at_points``: log|GH| and
    arg GH there) consistent with their limits at 0 and infinity (`engine.margins.pole_zero.certificate`)?"""
    mag0, mag_inf, phase0, phase_inf = levels.limits
    rows = [(at_points[0], maxima[0], mag0, mag_inf), (at_points[1], maxima[1], phase0, phase_inf)]
    ok = np.ones(levels.gain.size, dtype=bool)
    for (values, top, low, high), w in zip(rows, points):
        ok &= reach_limits(w, values, top, low, high)
    return ok


def reach_limits(w: NDArray, values: NDArray, top: NDArray, low: NDArray, high: NDArray) -> NDArray[np.bool_]:
    """Per sample: are a level's ``values`` at its stationary points ``w`` (maxima: ``top``) consistent
    with its limits ``low`` at 0 and ``high`` at infinity: the first maximum not below the limit at 0,
    the last not below the limit at infinity (minima alike), a level with none not equal at both ends?"""
    count = np.isfinite(w).sum(axis=1)
    ok = np.where(count == 0, ~near_limit(low, high), True)
    last = np.maximum(count - 1, 0)[:, None]
    if not w.shape[1]:
        return ok
    for value, peak, limit in (
        (values[:, 0], top[:, 0], low),
        (np.take_along_axis(values, last, 1)[:, 0], np.take_along_axis(top, last, 1)[:, 0], high),
    ):
        wrong = np.where(peak, value < limit, value > limit)
        ok &= (count == 0) | near_limit(value, limit) | ~wrong
    return ok


def _crossings(
    levels: BatchLevels, at_points: list[NDArray], gains: NDArray, phases: NDArray, polished: bool
) -> tuple[list[NDArray], list[NDArray], NDArray[np.bool_]]:
    """The crossings polished ((S, a) each, NaN-padded), GH at them, and whether each sample's
    are as many as the monotone pieces between the stationary points (``at_points``: log|GH| and
    arg GH at them) hold, each within 4 ulp (or in the rounding noise, when ``polished`` on the
    loop's own GH after)."""
    gain, _, noisy = _newton(levels, gains, 3)
    phase, _, noisy_phase = _newton(levels, phases, 4)
    gain, phase = distinct_rows(gain, gain)[0], distinct_rows(phase, phase)[0]
    phase_gh = levels.terms(phase)[0]
    phase = np.where(phase_gh.real < 0, phase, np.nan)
    phase, _ = distinct_rows(phase, phase)
    mag0, mag_inf, phase0, phase_inf = levels.limits
    held = _enclosed(_ends(mag0, at_points[0], mag_inf), False)
    held_phase = _enclosed(_ends(phase0, at_points[1], phase_inf), True)
    ok = (np.isfinite(gain).sum(axis=1) == held) & (np.isfinite(phase).sum(axis=1) == held_phase)
    gain_gh, gain_u = levels.terms(gain)
    phase_gh, phase_u = levels.terms(phase)
    ok &= (
        (polished | (~noisy & ~noisy_phase))
        & _conditioned(levels, gain_u, gain_u.imag)
        & _conditioned(levels, phase_u, phase_u.real)
    )
    return [gain, phase], [gain_gh, phase_gh], ok & _phase_margins_resolved(levels, gain_gh)


def _conditioned(levels: BatchLevels, u: NDArray, slope: NDArray) -> NDArray[np.bool_]:
    """Per sample: is every crossing determined to within `CONDITION` of GH?  A level read to
    a few ulp per root places its crossing to that over its slope (``slope``: the level's
    d/domega), where GH moves by |u| per unit of omega; near a tangent crossing the slope
    vanishes and the per-loop search, stopping elsewhere in the rounding, finds other margins."""
    spread = ROUNDING * levels.roots.shape[1] * np.abs(u) / np.abs(slope)
    return ~(spread > CONDITION).any(axis=1)


def _phase_margins_resolved(levels: BatchLevels, gh: NDArray) -> NDArray[np.bool_]:
    """Per sample: is every phase margin (arg GH + 180 deg at a gain crossover) larger than the
    two paths' difference in it over `CONDITION`?  Both evaluate GH by the same products from
    roots that agree to about an ulp, so arg GH differs by about an ulp a root (radians,
    whatever the margin's size; 8e-17 rad measured at worst on 1440 light-mode samples): a
    margin of 1e-11 rad (a crossover at 1e-11 rad/s of a type-2 loop) is not resolved to 1e-12
    of itself, on either path."""
    with np.errstate(all="ignore"):
        margin = np.abs(np.angle(-gh))
    return ~(EPS * levels.roots.shape[1] > CONDITION * np.where(np.isnan(margin), np.inf, margin)).any(axis=1)


def _ends(low: NDArray, values: NDArray, high: NDArray) -> NDArray:
    """Each row's piece ends: the limit at 0, the values at the stationary points, the limit at
    infinity right after the last (NaN after it)."""
    count = np.isfinite(values).sum(axis=1)
    ends = np.full((values.shape[0], values.shape[1] + 2), np.nan)
    ends[:, 0] = low
    ends[:, 1:-1] = values
    np.put_along_axis(ends, (count + 1)[:, None], high[:, None], 1)
    return ends


def _enclosed(ends: NDArray, phase: bool) -> NDArray:
    """How many target levels (0 for log|GH|, 180 deg mod 360 for the phase) each row's monotone
    pieces cross (`engine.margins.pole_zero.crossings.enclosed`)."""
    a, b = ends[:, :-1], ends[:, 1:]
    valid = ~np.isnan(a) & ~np.isnan(b)
    low, high = np.fmin(a, b), np.fmax(a, b)
    if phase:
        f = lambda v: (v - math.pi) / (2 * math.pi)  # noqa: E731
        count = np.maximum(np.ceil(f(high)) - np.floor(f(low)) - 1, 0)
        nearest = lambda v: math.pi + 2 * math.pi * np.round(f(v))  # noqa: E731
    else:
        count = ((low < 0) & (high > 0)).astype(float)
        nearest = lambda v: np.zeros_like(v)  # noqa: E731
    pieces = valid.sum(axis=1)
    first = np.arange(a.shape[1])[None, :] == 0
    last = np.arange(a.shape[1])[None, :] == (pieces - 1)[:, None]
    for end, outer in ((a, first), (b, last)):
        target = nearest(np.where(np.isfinite(end), end, 0.0))
        hugs = outer & np.isfinite(end) & (np.abs(end - target) <= LIMIT_NOISE) & (low < target) & (target < high)
        count = count - hugs
    return np.where(valid, count, 0).sum(axis=1)


def closed_loop_poles(levels: BatchLevels) -> NDArray[np.complex128]:
    """The closed-loop poles, the roots of D + k N (the variable scaled); NaN rows where they
    cannot be had."""
    scale, (numerator, denominator) = levels.scale, levels.scaled
    factor = (levels.gain * scale ** (numerator.shape[1] - denominator.shape[1]))[:, None]
    roots, bad = batch_roots(aligned_sum(denominator, factor * numerator))
    return np.where(bad[:, None], np.nan, roots * scale[:, None])

"""Peaks of closed-loop magnitudes of a loop in pole-zero form, without a grid.

The closed-loop transfers a designer bounds are Moebius transforms of GH,
f = (a + b GH)/(1 + GH): S (a = 1, b = 0), T (a = 0, b = 1) and the disk
margin's S + (sigma - 1)/2 (a = (1 + sigma)/2, b = (sigma - 1)/2).  With
GH = k N/D, f = (a D + b k N)/(D + k N), so on s = j omega

    d/domega log|f| = omega (sum_c' 1/(x + c'^2) - sum_c 1/(x + c^2)),

c' the roots of a D + b k N and c those of D + k N (x = omega^2): the
stationary points of |f| are the zeros of a sum of fractions (`engine.numerics.fraction_sums`),
polished by Newton's method on the exact form (slopes from GH, u = d log GH/ds
and du/ds: `engine.margins.pole_zero.levels`), certified and repaired as the margins'
are (`engine.margins.pole_zero.certificate`).  The peak over a band is the largest of the
maxima inside it and its ends (limits at 0 and infinity).  A multiple of S
(b = 0) is stationary where |1 + GH| is: when the margin search of the same
form has certified those points (`LoopLevels.certified_distance`), they are
taken, not searched again.  None whenever the method does not apply;
`engine.margins.peaks` then searches a grid.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from engine.loop.pole_zero import ZpkEvaluator
from engine.margins.pole_zero.certificate import certified
from engine.margins.pole_zero.levels import LoopLevels
from engine.margins.pole_zero.search import degenerate, distinct, newton, real_eigenvalues
from engine.numerics.fraction_sums import Fractions, polynomial_sum, roots

Moebius = tuple[float, float]  # (a, b): f = (a + b GH)/(1 + GH)


def moebius_peaks(
    form: ZpkEvaluator, transforms: list[Moebius], low: float = 0.0, high: float = math.inf
) -> list[tuple[float, float]] | None:
    """Per transform, (max |f| over [low, high], where: 0 or inf for a limit at an end);
    None when the method does not apply or a check fails."""
    loop = LoopLevels.of(form)
    if loop is None or not all(_proper(loop, ab) for ab in transforms) or degenerate(loop):
        return None  # degenerate: GH on the negative real axis everywhere (1/s**2) or |GH| = 1 (the grid names it)
    known = loop.certified_distance  # the margin search's, when it ran: |a / (1 + GH)| peaks at its minima
    reused = [known is not None and ab[1] == 0 for ab in transforms]
    searched = [ab for ab, taken in zip(transforms, reused) if not taken]
    found = _stationary(loop, searched) if searched else ([], [])
    if found is None:
        return None
    maxima = iter(points[top] for points, top in zip(*found))
    return [
        _peak(loop, ab, known[0][~known[1]] if taken else next(maxima), low, high)
        for ab, taken in zip(transforms, reused)
    ]


def _stationary(loop: LoopLevels, transforms: list[Moebius]) -> tuple[list[NDArray], list[NDArray]] | None:
    """Per transform, the stationary points of |f| and which are maxima, certified; None when a check fails."""
    with np.errstate(all="ignore"):
        starts = _starts(loop, transforms)
        if starts is None:
            return None
        w, kind, near, constant = starts

        def slopes(omega: NDArray) -> tuple[NDArray, NDArray]:
            return _moebius_slopes(loop, omega, transforms)

        found = distinct(*newton(slopes, w, kind), kinds=len(transforms))
        if found is None:
            return None
        return certified(
            loop,
            found[0],
            found[1],
            near,
            slopes,
            ends=_ends(loop, transforms),
            noise=lambda omega: _moebius_noise(loop, omega, transforms),
            constant=constant,
        )


def _ends(loop: LoopLevels, transforms: list[Moebius]):
    """log|f| of each transform at given frequencies, and its limits at 0 and infinity."""

    def levels(omega: NDArray) -> NDArray:
        gh = loop.terms(omega)[0]
        return np.array([np.log(np.abs(moebius(ab, gh))) for ab in transforms])

    def log(value: float) -> float:
        return math.log(value) if value > 0 else -math.inf

    return levels, [(log(_limit(loop, ab, 0.0)), log(_limit(loop, ab, math.inf))) for ab in transforms]


def _proper(loop: LoopLevels, ab: Moebius) -> bool:
    """a D + b k N has no more roots than D + k N (a proper loop) and is not 0."""
    return (ab[0] != 0 or ab[1] != 0) and loop.form.zeros.size <= loop.form.poles.size


def _numerator_roots(loop: LoopLevels, ab: Moebius) -> NDArray:
    """The roots of a D + b k N."""
    a, b = ab
    return roots(polynomial_sum(a * loop.denominator, b * loop.gain * loop.numerator))


def _starts(loop: LoopLevels, transforms: list[Moebius]) -> tuple[NDArray, NDArray, NDArray, list[bool]] | None:
    """Newton's starts (the positive real zeros of each transform's sum) with the
    transform's number, the near-real zeros' frequencies (check points), and
    which transforms are constant (their sums vanish: the disk margin's
    (1 - GH)/(1 + GH) of K/s, all-pass): those have no stationary points.
    A multiple of S (b = 0) is stationary where |1 + GH| is: its starts are
    also `distance_stationary`'s (whose residue form keeps the digits the
    difference of sums loses where a closed-loop pole is near an open-loop one).
    So are any transform's with a != 0: near a lightly damped mode, and where
    |GH| is small (log|f| ~ log|a| + (b/a - 1) Re GH), its stationary points
    lie by those of |1 + GH|, where its own sums cancel; the certificate had
    to bracket each one missed (five for the disk margin of an order-18 loop
    with six light modes).  The starts are kept per loop (`LoopLevels`): the
    margin search has made them when analyze gets here."""
    starts, kinds, near, constant = [], [], [], []
    for number, ab in enumerate(transforms):
        top = _numerator_roots(loop, ab)
        fractions = Fractions(-(np.concatenate([top, loop.closed]) ** 2))
        weights = fractions.weights(np.concatenate([np.ones(top.size), -np.ones(loop.closed.size)]).astype(complex))
        constant.append(weights is None)
        x = np.zeros(0, dtype=complex) if constant[-1] else fractions.zeros_of(weights)
        if x is None:
            return None
        extra = loop.distance_starts if ab[0] != 0 and not constant[-1] else None
        if extra is not None:
            x = np.concatenate([x, extra])
        real, close = real_eigenvalues(x)
        starts.append(np.sqrt(x.real[real]))
        kinds.append(np.full(starts[-1].size, number))
        near.append(close)
    return np.concatenate(starts), np.concatenate(kinds), np.concatenate(near), constant


def _moebius_slopes(loop: LoopLevels, w: NDArray, transforms: list[Moebius]) -> tuple[NDArray, NDArray]:
    """Rows per transform: d log|f| / domega and its derivative (`moebius_slopes`)."""
    gh, u, du = loop.terms(w)
    rows = [moebius_slopes(ab, gh, u, du) for ab in transforms]
    return np.array([first for first, _ in rows]), np.array([second for _, second in rows])


def moebius_slopes(ab: Moebius, gh: NDArray, u: NDArray, du: NDArray) -> tuple[NDArray, NDArray]:
    """d log|f| / domega and its derivative from GH, u = d log GH / ds and du/ds.  With A = a + b GH
    and C = 1 + GH, d/ds log f = b GH u / A - GH u / C = (b - a) GH u / (A C), and
    its derivative (b - a) GH / (A C) (u^2 + u' - u^2 GH (b C + A) / (A C)): no
    difference of two nearly equal terms (|T| of a type-2 loop is 1 to 1e-12 at
    low frequency, and its slope that small, not the rounding of 1)."""
    a, b = ab
    top, bottom = a + b * gh, 1.0 + gh
    base = (b - a) * gh / (top * bottom)
    square = u * u
    first = -(base * u).imag
    return first, -(base * (square + du - square * gh * (b * bottom + top) / (top * bottom))).real


def _moebius_noise(loop: LoopLevels, w: NDArray, transforms: list[Moebius]) -> NDArray:
    """Rows per transform: the rounding of `_moebius_slopes`' first rows (`moebius_noise`)."""
    gh, noise = loop.u_rounding(w)
    return np.array([moebius_noise(ab, gh, noise) for ab in transforms])


def moebius_noise(ab: Moebius, gh: NDArray, u_noise: NDArray) -> NDArray:
    """The rounding of `moebius_slopes`' first (as `LoopLevels.slope_noise`: a part of
    (b - a) GH u / (A C), each factor a few ulp per root, u's error ``u_noise``)."""
    a, b = ab
    return np.abs((b - a) * gh / ((a + b * gh) * (1.0 + gh))) * u_noise


def _peak(loop: LoopLevels, ab: Moebius, maxima: NDArray, low: float, high: float) -> tuple[float, float]:
    """The largest |f| at the maxima within [low, high] and at its ends."""
    inside = maxima[(maxima >= low) & (maxima <= high)]
    ends = [w for w in (low, high) if 0 < w < math.inf]
    points = np.concatenate([inside, ends])
    values = np.abs(moebius(ab, loop.terms(points)[0])) if points.size else np.zeros(0)
    candidates = list(zip(values.tolist(), points.tolist()))
    for w, limit in ((0.0, low == 0.0), (math.inf, high == math.inf)):
        if limit:
            candidates.append((_limit(loop, ab, w), w))
    return max(candidates)


def moebius(ab: Moebius, gh: NDArray) -> NDArray:
    """f = (a + b GH)/(1 + GH), from 1/GH where |GH| > 1."""
    a, b = ab
    return np.where(np.abs(gh) > 1.0, (a / gh + b) / (1.0 / gh + 1.0), (a + b * gh) / (1.0 + gh))


def _limit(loop: LoopLevels, ab: Moebius, w: float) -> float:
    """|f| as omega -> 0 (w = 0) or -> infinity: GH tends to 0, infinity or a real number."""
    (zero, top), _ = loop.limits
    level = zero if w == 0.0 else top
    a, b = ab
    if level == math.inf:
        return abs(b)
    if level == -math.inf:
        return abs(a)
    at = 0.0 if w == 0.0 else math.inf
    gh = loop.form.gain.real if at == math.inf else complex(loop.form(np.zeros(1))[0][0])
    return float(abs(moebius(ab, np.array([gh]))[0]))

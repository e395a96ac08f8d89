"""The crossings of a loop in pole-zero form (`engine.margins.pole_zero.search`): gain
crossovers (|GH| = 1) and phase crossings of the negative real axis
(arg GH = 180 deg mod 360).

Their starting points are the real roots of two small expanded polynomials
(|GH|^2 = 1 and Im GH = 0, in x = omega^2); every one is polished with the
stationary points.  log |GH| and arg GH are monotone between consecutive
stationary points of their own, so the number of crossings each piece holds
is known from the levels at its ends (or their limits at 0 and infinity).
When the polished crossings are not that many (an expanded polynomial lost
a root: a crossover at 1e-17 rad/s of a loop whose gain is tiny), every
crossing of that level is found piece by piece instead: bracketed between
the piece's ends (an end at 0 or infinity replaced by the first of the
points decades beyond the other where the level is past the target) and
refined to 4 ulp (`engine.numerics.bracketing`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from engine.margins.pole_zero.levels import LoopLevels
from engine.numerics.bracketing import bracketed_roots
from engine.numerics.fraction_sums import poly, polynomial_sum, roots

NEAR_REAL = 1e-2  # |Im x| / |x| below which a polynomial's root is a start
LIMIT_NOISE = 1e-9  # a level this close to its limit at 0 or infinity is at the limit
FAR_DECADES = 300  # how far beyond a piece's finite end a crossing is looked for


def crossing_candidates(loop: LoopLevels) -> tuple[NDArray, NDArray]:
    """Starts for the gain crossovers (roots of k^2 N(x) - D(x), N and D the
    products of x + r^2 over zeros and poles) and the phase crossings (roots of
    Im N(j w) D(-j w) / w as a polynomial in x), in a frequency scaled by the
    roots' geometric mean (so the coefficients do not overflow); the crossovers'
    none when the scaled gain's square would."""
    form, scale = loop.form, loop.scale
    zeros, poles = form.zeros / scale, form.poles / scale
    log_gain = math.log(abs(loop.gain)) + (zeros.size - poles.size) * math.log(scale)
    gains = np.zeros(0)
    if abs(log_gain) < 300:
        difference = polynomial_sum(poly(-(poles**2)), -math.exp(2 * log_gain) * poly(-(zeros**2)))
        gains = _positive_roots(difference) * scale
    den = poly(poles)
    mirrored = den * (-1.0) ** np.arange(den.size - 1, -1, -1)  # D(-s)
    product = np.convolve(poly(zeros), mirrored)[::-1]  # ascending powers of s
    odd = product[1::2] * (-1.0) ** np.arange(product[1::2].size)  # Im at s = j w, over w: a polynomial in x
    return gains, _positive_roots(odd[::-1]) * scale


def _positive_roots(coefficients: NDArray) -> NDArray:
    """sqrt of the real positive roots (to `NEAR_REAL`) of a polynomial in x."""
    x = roots(coefficients)
    keep = (x.real > 0) & (np.abs(x.imag) <= NEAR_REAL * np.abs(x))
    return np.sqrt(x.real[keep])


def crossings_of(loop: LoopLevels, points: list[NDArray]) -> tuple[NDArray, NDArray] | None:
    """(gain crossovers, negative-real-axis crossings): the polished ones
    (``points[3]``, ``points[4]``) when they are as many as the pieces between
    the stationary points of log|GH| (``points[0]``) and arg GH (``points[1]``)
    hold, else found piece by piece; None when that fails too."""
    mag_limits, phase_limits = loop.limits
    levels = (
        (points[0], np.log(np.abs(loop.terms(points[0])[0])), mag_limits, False),
        (points[1], loop.phase(points[1]), phase_limits, True),
    )
    found = [points[3], points[4][loop.terms(points[4])[0].real < 0]]
    out = []
    for (w, values, limits, phase), polished in zip(levels, found):
        ends = np.concatenate([[limits[0]], values, [limits[1]]])
        if polished.size == enclosed(ends, phase):
            out.append(polished)
            continue
        pieces = _piece_brackets(loop, np.concatenate([[0.0], w, [math.inf]]), ends, phase)
        crossing = None if pieces is None else _refined(loop, *pieces, phase)
        if crossing is None:
            return None
        out.append(np.sort(crossing))
    return out[0], out[1]


def enclosed(values: NDArray, phase: bool) -> int:
    """How many target levels a monotone level crosses from piece end to piece end
    (0 for log|GH|; 180 deg mod 360 for the phase; not at the outer limits themselves)."""
    return sum(len(_targets(values, k, phase)) for k in range(values.size - 1))


def _targets(values: NDArray, k: int, phase: bool) -> list[float]:
    """The target levels strictly between values[k] and values[k + 1] (a limit
    at the outer ends within `LIMIT_NOISE` of a target does not count: |GH(0)| = 1
    or GH(0) real negative is not a crossing)."""
    a, b = float(values[k]), float(values[k + 1])
    low, high = min(a, b), max(a, b)
    if phase:
        first = math.floor((low - math.pi) / (2 * math.pi))
        levels = [math.pi + 2 * math.pi * q for q in range(first, first + int((high - low) / (2 * math.pi)) + 3)]
    else:
        levels = [0.0]  # log|GH| = 0
    outer = [v for v, end in ((a, k == 0), (b, k == values.size - 2)) if end]
    return [v for v in levels if low < v < high and all(abs(v - o) > LIMIT_NOISE for o in outer)]


def _piece_brackets(
    loop: LoopLevels, edges: NDArray, ends: NDArray, phase: bool
) -> tuple[NDArray, NDArray, NDArray] | None:
    """(lo, hi, target) of every crossing, one bracket per target in its piece."""
    lo, hi, target = [], [], []
    for k in range(ends.size - 1):
        for level in _targets(ends, k, phase):
            a, b = float(edges[k]), float(edges[k + 1])
            if a == 0.0 or not math.isfinite(b):
                a, b = _finite(loop, a, b, level, phase)
                if a is None:
                    return None
            lo.append(a)
            hi.append(b)
            target.append(level)
    return np.array(lo), np.array(hi), np.array(target)


def _finite(loop: LoopLevels, a: float, b: float, level: float, phase: bool) -> tuple[float | None, float]:
    """A finite bracket within (a, b) across ``level``: an end at 0 or infinity
    replaced by the first point `FAR_DECADES` beyond the other end, or beyond the
    loop's own scale when neither is finite, where the level is past ``level``."""
    if a == 0.0 and not math.isfinite(b):
        middle = float(loop.scale)
        value = float(_level(loop, np.array([middle]), phase)[0])
        below = (value - level) * (float(_level(loop, np.array([middle * 1e-300]), phase)[0]) - level) < 0
        return _finite(loop, 0.0, middle, level, phase) if below else _finite(loop, middle, math.inf, level, phase)
    down = a == 0.0
    anchor = b if down else a
    own = float(_level(loop, np.array([anchor]), phase)[0])
    steps = anchor * 10.0 ** (np.arange(1, FAR_DECADES + 1) * (-1.0 if down else 1.0))
    steps = steps[(steps > 0) & np.isfinite(steps)]
    across = np.flatnonzero((_level(loop, steps, phase) - level) * (own - level) < 0)
    if across.size == 0:
        return None, b
    far = float(steps[across[0]])
    return (far, anchor) if down else (anchor, far)


def _level(loop: LoopLevels, w: NDArray, phase: bool) -> NDArray:
    return loop.phase(w) if phase else np.log(np.abs(loop.terms(w)[0]))


def _refined(loop: LoopLevels, lo: NDArray, hi: NDArray, target: NDArray, phase: bool) -> NDArray | None:
    """The root of level - target in each [lo, hi] (the level monotone there)."""
    row = 1 if phase else 0

    def fun(w: NDArray, which: NDArray) -> tuple[NDArray, NDArray]:
        return _level(loop, w, phase) - target[which], loop.slopes(w)[0][row]

    return bracketed_roots(fun, lo, hi)

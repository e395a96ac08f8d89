"""Margins of a rational loop in pole-zero form, without a detection grid.

On s = j omega, with x = omega**2 and the loop's roots r (zeros sigma = +1,
poles sigma = -1), each level the margins read has a derivative that is a sum
of simple fractions in x with poles at t = -r**2:

    d/domega log|GH|    = omega sum sigma / (x + r**2)
    d/domega arg GH     = -sum sigma r / (x + r**2)
    d/domega log|1+GH|  = omega (sum_c 1/(x + c**2) - sum_p 1/(x + p**2))

(c: the closed-loop poles, the zeros of 1 + GH).  Their zeros, the levels'
stationary points, are eigenvalues found without expanding a polynomial
(`engine.fractions`).  The real positive ones are polished by Newton's
method on the exact pole-zero form (maxima of |GH| are the attenuation
margins, minima of |1 + GH| the stability margins) and certified: the
stationary points of a smooth level alternate between maxima and minima, and
its slope has the sign that order predicts at check points between and
around them, at the roots' own frequencies, on a ladder two points a decade
wide from 1e-3 of the smallest root to 1e3 times the largest, and at every
near-real eigenvalue (where a close pair could hide).  Between consecutive
stationary points log|GH| and arg GH are monotone, so the gain crossovers
and the phase crossovers (arg GH = 180 deg mod 360) are exactly the
crossings of their levels between consecutive check points (or beyond the
last, towards the level's limit): bracketed there and refined by
safeguarded Newton steps to 4 ulp.  Whenever a condition of the method fails
(roots on the imaginary axis, a constant level, a check, a step limit) the
answer is None and `engine.margins` takes the detection grid instead.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from .fractions import fraction_zeros, poly, roots
from .zpk import ZpkEvaluator

MAX_ROOTS = 48  # zeros + poles; beyond, the detection grid is faster (docs/margins.md)
UNDAMPED = 1e-9  # |Re r| / |r| at or below which a root is on the imaginary axis
REAL = 1e-7  # |Im x| / |x| below which an eigenvalue is a real stationary point
NEAR_REAL = 1e-2  # ... below which a close real pair could hide near it (a check point there)
DUPLICATE = 1e-9  # relative distance at which two polished points are one
NEWTON_STEPS = 12
NOISE_STEP = 1e-9  # relative step below which steps that stop shrinking are rounding noise
PROBE_RANGE = 1e3  # check points from the smallest root / this to the largest * this
PROBES_PER_DECADE = 2
LIMIT_NOISE = 1e-9  # a level this close to its limit at 0 or infinity is at the limit
EPS = np.finfo(float).eps
KINDS = ("mag", "phase", "dist")  # log|GH|, arg GH, log|1 + GH|


def fast_margins(form: ZpkEvaluator) -> dict[str, NDArray[np.float64]] | None:
    """Frequencies of the gain crossings of the negative real axis ("G"), the
    gain crossovers ("P"), the minima of |1 + GH| ("S") and the maxima of |GH|
    ("A"); None when the method does not apply or a check fails."""
    loop = _Loop.of(form)
    if loop is None:
        return None
    with np.errstate(all="ignore"):
        starts = _starts(loop)
        if starts is None:
            return None  # a constant level: the detection grid names it
        w, kind, near = starts
        w, second, converged = _newton(loop, w, kind)
        found = [_distinct(w[converged & (kind == k)], second[converged & (kind == k)]) for k in range(5)]
        if any(f is None for f in found):
            return None
        points, maxima = [f[0] for f in found[:3]], [f[1] < 0 for f in found[:3]]
        if not _certified(loop, points, maxima, near):
            return None
        crossings = _crossings(loop, points, found[3][0], found[4][0])
    if crossings is None:
        return None
    return {"G": crossings[1], "P": crossings[0], "S": points[2][~maxima[2]], "A": points[0][maxima[0]]}


class _Loop:
    """The roots of GH (signs +1 zeros, -1 poles), its gain, closed-loop poles and check points."""

    def __init__(self, form: ZpkEvaluator, closed: NDArray, numerator: NDArray, denominator: NDArray):
        self.form = form
        self.roots = np.concatenate([form.zeros, form.poles])
        self.signs = np.concatenate([np.ones(form.zeros.size), -np.ones(form.poles.size)])
        self.gain = float(form.gain.real)
        self.closed = closed
        self.numerator, self.denominator = numerator, denominator
        nonzero = np.abs(self.roots[self.roots != 0])
        low, high = (float(nonzero.min()), float(nonzero.max())) if nonzero.size else (1.0, 1.0)
        self.scale = math.sqrt(low * high)
        count = PROBES_PER_DECADE * math.ceil(math.log10(high / low) + 2 * math.log10(PROBE_RANGE)) + 1
        self.probes = np.concatenate([nonzero, np.geomspace(low / PROBE_RANGE, high * PROBE_RANGE, count)])
        # arg(j w - r) = offset + turn * atan2(w - Im r, |Re r|), continuous in w > 0 (r = 0: pi/2)
        right = self.roots.real > 0
        self.phase_offset = (math.pi if self.gain < 0 else 0.0) + math.pi * float(self.signs[right].sum())
        self.phase_turn = np.where(right, -self.signs, self.signs)
        self.imag = self.roots.imag[:, None]
        self.damping = np.abs(self.roots.real)[:, None]

    @staticmethod
    def of(form: ZpkEvaluator) -> _Loop | None:
        """The loop when the method applies: few roots, none on the imaginary
        axis but at 0, a real nonzero gain."""
        roots = np.concatenate([form.zeros, form.poles])
        if roots.size > MAX_ROOTS or form.poles.size == 0 or form.gain.imag != 0 or form.gain == 0:
            return None
        size = np.abs(roots)
        if not np.isfinite(size).all() or ((size > 0) & (np.abs(roots.real) <= UNDAMPED * size)).any():
            return None
        numerator, denominator = poly(form.zeros), poly(form.poles)
        closed = _closed_loop_poles(form.gain.real * numerator, denominator)
        return None if closed is None else _Loop(form, closed, numerator, denominator)

    def fractions(self, kind: str) -> tuple[NDArray, NDArray]:
        """(t, a) of the level's derivative sum a / (x - t) (module docstring)."""
        if kind == "mag":
            return -self.roots ** 2, self.signs.astype(complex)
        if kind == "phase":
            return -self.roots ** 2, -self.signs * self.roots
        both = np.concatenate([self.closed, self.form.poles])
        return -both ** 2, np.concatenate([np.ones(self.closed.size), -np.ones(self.form.poles.size)]).astype(complex)

    def terms(self, w: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """GH, u = d log GH / ds and du/ds at s = j w."""
        form, m = self.form, self.form.paired
        q = 1j * w - form.roots
        r = 1.0 / q
        gh = form.gain * np.multiply.reduce(q[:m] * r[m:2 * m], axis=0)  # paired as `ZpkEvaluator` does
        if form.roots.size > 2 * m:
            gh = gh * np.multiply.reduce(q[2 * m:] if form.extra_zeros else r[2 * m:], axis=0)
        return gh, form.signs @ r, -(form.signs @ (r * r))

    def slopes(self, w: NDArray) -> tuple[NDArray, NDArray]:
        """Rows: each level's derivative in omega and its own derivative, for
        the stationary points of `KINDS` (log|GH|, arg GH, log|1 + GH|), then
        the levels log|GH| and Im GH themselves with their derivatives (the
        crossings): Newton's step on row k is first[k] / second[k]."""
        gh, u, du = self.terms(w)
        g = gh * u / (1.0 + gh)  # d log(1 + GH) / ds
        dg = gh * (u * u + du) / (1.0 + gh) - g * g
        first = np.array([-u.imag, u.real, -g.imag, np.log(np.abs(gh)), gh.imag])
        second = np.array([-du.real, -du.imag, -dg.real, -u.imag, (gh * u).real])
        return first, second

    def phase(self, w: NDArray) -> NDArray:
        """arg GH(j w), continuous in w > 0 (each root's angle on its own branch)."""
        return self.phase_offset + self.phase_turn @ np.arctan2(w - self.imag, self.damping)

    def limits(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """(log|GH|, arg GH) as omega -> 0 and as omega -> infinity."""
        at_zero = self.roots == 0
        n0, excess = float(self.signs[at_zero].sum()), float(self.signs.sum())
        rest = math.log(abs(self.gain)) + float(self.signs[~at_zero] @ np.log(np.abs(self.roots[~at_zero])))
        mag = (-math.inf * n0 if n0 else rest, math.inf * excess if excess else math.log(abs(self.gain)))
        top = (math.pi if self.gain < 0 else 0.0) + math.pi / 2 * excess
        zero = float(self.phase(np.zeros(1))[0]) + math.pi / 2 * n0  # atan2(0, 0) is 0, the limit pi/2
        return mag, (zero, top)


def _closed_loop_poles(numerator: NDArray, denominator: NDArray) -> NDArray | None:
    """Zeros of 1 + GH: roots of D + k N (candidates only: every point found is polished on GH)."""
    size = max(denominator.size, numerator.size)
    char = np.zeros(size)
    char[size - denominator.size:] += denominator
    char[size - numerator.size:] += numerator
    if not np.isfinite(char).all():
        return None
    return roots(char)


def _starts(loop: _Loop) -> tuple[NDArray, NDArray, list[NDArray]] | None:
    """Newton's starting points and their kinds (0-2: the stationary points of
    `KINDS`, 3: gain crossovers, 4: phase crossings), and per stationary kind
    the near-real eigenvalues' frequencies (check points)."""
    starts, kinds, near = [], [], []
    for number, kind in enumerate(KINDS):
        x = fraction_zeros(*loop.fractions(kind))
        if x is None:
            return None
        positive = x.real > 0
        real = positive & (np.abs(x.imag) <= REAL * np.abs(x))
        starts.append(np.sqrt(x.real[real]))
        near.append(np.sqrt(x.real[positive & ~real & (np.abs(x.imag) <= NEAR_REAL * np.abs(x))]))
    starts += _crossing_candidates(loop)
    kinds = [np.full(part.size, number) for number, part in enumerate(starts)]
    return np.concatenate(starts), np.concatenate(kinds), near


def _certified(loop: _Loop, points: list[NDArray], maxima: list[NDArray], near: list[NDArray]) -> bool:
    """The stationary points of each level alternate between maxima and minima,
    and the slopes have the signs their order predicts at the check points."""
    probes, slopes = _probes(loop, points, near)
    return all(_alternate(points[k], maxima[k], probes, slopes[k]) for k in range(len(KINDS)))


def _newton(loop: _Loop, w: NDArray, kind: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Newton's method on each point's level slope: (w, second derivative,
    converged).  A point is done when its step is within 4 ulp, or when its
    steps, already below `NOISE_STEP`, stop shrinking: the slope's rounding
    noise is reached (a flat extremum is determined no better).  A point that
    does not converge (a spurious eigenvalue where the level is flat to
    rounding) is dropped; the certificate judges what is left."""
    done, previous, second = np.zeros(w.size, dtype=bool), np.full(w.size, np.inf), np.zeros(w.size)
    columns = np.arange(w.size)
    for _ in range(NEWTON_STEPS):
        first, bend = loop.slopes(w)
        first, bend = first[kind, columns], bend[kind, columns]
        second = np.where(done, second, bend)
        step = np.where(done, 0.0, first / bend)
        size = np.abs(step)
        finished = (size <= 4 * EPS * w) | ((size <= NOISE_STEP * w) & (size >= 0.5 * previous))
        moved = w - step
        lost = ~(np.isfinite(moved) & (moved > 0))
        w = np.where(lost, w, moved)
        done |= finished & ~lost
        previous = np.where(lost, np.inf, size)
        if (done | lost).all():
            break
    return w, second, done


def _distinct(w: NDArray, bends: NDArray) -> tuple[NDArray, NDArray] | None:
    """Sorted, duplicates (two starts that met) merged; None when one is degenerate
    (a zero second derivative: not a simple root)."""
    order = np.argsort(w)
    w, bends = w[order], bends[order]
    if w.size > 1:
        keep = np.concatenate([[True], np.diff(w) > DUPLICATE * w[1:]])
        w, bends = w[keep], bends[keep]
    return None if (bends == 0).any() else (w, bends)


def _probes(loop: _Loop, points: list[NDArray], near: list[NDArray]):
    """Check points (module docstring) away from every stationary point, with
    GH and every level's slope there."""
    every = np.concatenate(points)
    parts = [loop.probes] + near
    for w in points:
        if w.size:
            parts += [np.sqrt(w[1:] * w[:-1]), w[:1] / 4, w[-1:] * 4]
    probes = np.unique(np.concatenate(parts))
    if every.size:  # not within a hair of a stationary point, where a slope's sign is rounding
        gaps = np.min(np.abs(probes[:, None] / every[None, :] - 1.0), axis=1)
        probes = probes[gaps > 1e-6]
    return probes, loop.slopes(probes)[0]


def _alternate(w: NDArray, maxima: NDArray, probes: NDArray, slope: NDArray) -> bool:
    """Maxima and minima alternate, and at every check point the slope has the
    sign their order predicts (negative past a maximum, positive past a minimum)."""
    if w.size == 0:
        return bool((slope > 0).all() or (slope < 0).all())
    if w.size > 1 and (maxima[1:] == maxima[:-1]).any():
        return False
    after = np.where(maxima, -1.0, 1.0)
    position = np.searchsorted(w, probes)
    predicted = np.where(position == 0, -after[0], after[np.maximum(position - 1, 0)])
    return bool((np.sign(slope) == predicted).all())


def _crossing_candidates(loop: _Loop) -> tuple[NDArray, NDArray]:
    """Starting points for the gain crossovers (roots of k^2 N(x) - D(x), x =
    omega^2, N and D the products of x + r^2 over zeros and poles) and the
    phase crossings (roots of Im N(j w) D(-j w) / w as a polynomial in x).
    Expanded polynomials lose digits; these are only starts, every one
    polished on the pole-zero form and their count certified."""
    form = loop.form
    poles_x, zeros_x = poly(-form.poles ** 2), loop.gain ** 2 * poly(-form.zeros ** 2)
    gains = poles_x.copy()
    gains[poles_x.size - zeros_x.size:] -= zeros_x
    den = loop.denominator
    mirrored = den * (-1.0) ** np.arange(den.size - 1, -1, -1)  # D(-s)
    product = np.convolve(loop.numerator, mirrored)[::-1]  # ascending powers of s
    odd = product[1::2] * (-1.0) ** np.arange(product[1::2].size)  # Im at s = j w, over w: a polynomial in x
    return _positive_roots(gains), _positive_roots(odd[::-1])


def _positive_roots(coefficients: NDArray) -> NDArray:
    """sqrt of the real positive roots (to `NEAR_REAL`) of a polynomial in x."""
    x = roots(coefficients)
    keep = (x.real > 0) & (np.abs(x.imag) <= NEAR_REAL * np.abs(x))
    return np.sqrt(x.real[keep])


def _crossings(loop: _Loop, points: list[NDArray], gains: NDArray, phases: NDArray) -> tuple[NDArray, NDArray] | None:
    """The polished gain crossovers, and the phase crossings on the negative
    real axis (arg GH = 180 deg mod 360), certified by their count: log|GH| and
    arg GH are monotone between consecutive stationary points, so each piece
    holds the crossings its end values (or limits) enclose."""
    negative = phases[loop.terms(phases)[0].real < 0]
    (mag_limits, phase_limits) = loop.limits()
    magnitude = np.log(np.abs(loop.terms(points[0])[0]))
    expected_gain = _enclosed(np.concatenate([[mag_limits[0]], magnitude, [mag_limits[1]]]), False)
    expected_phase = _enclosed(np.concatenate([[phase_limits[0]], loop.phase(points[1]), [phase_limits[1]]]), True)
    if gains.size != expected_gain or negative.size != expected_phase:
        return None
    return gains, negative


def _enclosed(values: NDArray, phase: bool) -> int:
    """How many target levels a monotone level crosses from piece end to piece end
    (0 for log|GH|; 180 deg mod 360 for the phase; not at the outer limits themselves)."""
    if not phase:
        with np.errstate(invalid="ignore"):
            return int(np.count_nonzero(np.sign(values[1:]) * np.sign(values[:-1]) < 0))
    values = values.copy()
    turns = (values - math.pi) / (2 * math.pi)  # a target where this is an integer
    for end in (0, -1):  # a limit on a target is not crossed (GH(0) real negative)
        if abs(turns[end] - round(turns[end])) * 2 * math.pi <= LIMIT_NOISE:
            turns[end] = round(turns[end]) + (0.5 if turns[end + (1 if end == 0 else -1)] > turns[end] else -0.5) * 1e-9
    below = np.floor(turns)
    return int(np.sum(np.abs(below[1:] - below[:-1])))

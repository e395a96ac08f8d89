"""The levels a margin search in pole-zero form reads (`engine.margins.pole_zero.search`):
log |GH|, arg GH (continuous) and log |1 + GH| at s = j omega, their slopes
and second derivatives from the roots (u = d log GH / ds = sum sigma / (s - r),
du/ds = -sum sigma / (s - r)^2), their limits at 0 and infinity, and the
sums of fractions whose zeros are the stationary points of log |1 + GH|."""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from engine.derived import Form
from engine.loop.pole_zero import ZpkEvaluator
from engine.model.paired_product import ProductTerms
from engine.numerics.fraction_sums import Fractions, poly, polynomial_sum, roots

MAX_ROOTS = 48  # zeros + poles; beyond, the detection grid is faster (docs/margins.md)
UNDAMPED = 1e-9  # |Re r| / |r| at or below which a root is on the imaginary axis
PROBE_DECADES = 3  # check points from the smallest root / 10**this to the largest * 10**this
PROBES_PER_DECADE = 2
UNIT_GAIN_REACH = 1e6  # the check points follow |GH|'s unit-gain asymptotes this far beyond the roots
LEVELS: Form[LoopLevels | None] = Form("levels")  # kept on a pole-zero form: its margins and peaks share it
ROUNDING = 8 * np.finfo(float).eps  # a slope's rounding, relative to the sizes it is formed from


class LoopLevels:
    """The roots of GH (signs +1 zeros, -1 poles), its gain, closed-loop poles and check points."""

    def __init__(self, form: ZpkEvaluator, closed: NDArray, numerator: NDArray, denominator: NDArray):
        self.form, self.closed = form, closed
        self.roots = np.concatenate([form.zeros, form.poles])
        self.signs = np.concatenate([np.ones(form.zeros.size), -np.ones(form.poles.size)])
        self.gain = float(form.gain.real)
        self.numerator, self.denominator = numerator, denominator
        nonzero = np.abs(self.roots[self.roots != 0])
        low, high = (float(nonzero.min()), float(nonzero.max())) if nonzero.size else (1.0, 1.0)
        self.scale = math.sqrt(low * high)
        reach = [min(max(w, low * UNIT_GAIN_REACH**-1), high * UNIT_GAIN_REACH) for w in self._unit_gains()]
        low, high = min([low] + reach), max([high] + reach)
        decades = math.ceil(math.log10(high) - math.log10(low)) + 2 * PROBE_DECADES  # high / low may overflow
        ladder = low * 10.0 ** (np.arange(PROBES_PER_DECADE * decades + 1) / PROBES_PER_DECADE - PROBE_DECADES)
        self.probes = np.concatenate([nonzero, ladder])
        # arg(j w - r) = offset + turn * atan2(w - Im r, |Re r|), continuous in w > 0 (r = 0: pi/2)
        right = self.roots.real > 0
        self.phase_offset = (math.pi if self.gain < 0 else 0.0) + math.pi * float(self.signs[right].sum())
        self.phase_turn = np.where(right, -self.signs, self.signs)
        self.imag, self.damping = self.roots.imag[:, None], np.abs(self.roots.real)[:, None]
        # the stationary points of log |1 + GH| and which are maxima, once the margin search has certified them
        self.certified_distance: tuple[NDArray, NDArray] | None = None

    def _unit_gains(self) -> list[float]:
        """Where the asymptotes of |GH| at 0 and at infinity cross 1 (features a gain
        places far from every root lie there: the check points reach them)."""
        n0, excess, low_level = self.asymptotes
        logs = [-low_level / n0 if n0 else None, -math.log(abs(self.gain)) / excess if excess else None]
        return [math.exp(x) for x in logs if x is not None and -700.0 < x < 700.0]  # within the float range

    @cached_property
    def asymptotes(self) -> tuple[float, float, float]:
        """|GH| ~ exp(low_level) omega^n0 as omega -> 0 and |k| omega^excess as omega -> inf:
        (n0, excess, low_level)."""
        at_zero = self.roots == 0
        n0, excess = float(self.signs[at_zero].sum()), float(self.signs.sum())
        low_level = math.log(abs(self.gain)) + float(self.signs[~at_zero] @ np.log(np.abs(self.roots[~at_zero])))
        return n0, excess, low_level

    @staticmethod
    def of(form: ZpkEvaluator) -> LoopLevels | None:
        """The loop when the method applies: few roots, none on the imaginary
        axis but at 0, a real nonzero gain (built once per form: kept in its ``derived``)."""
        return form.derived.get(LEVELS, lambda: LoopLevels._built(form))

    @staticmethod
    def _built(form: ZpkEvaluator) -> LoopLevels | None:
        roots = np.concatenate([form.zeros, form.poles])
        if roots.size > MAX_ROOTS or form.poles.size == 0 or form.gain.imag != 0 or form.gain == 0:
            return None
        size = np.abs(roots)
        if not np.isfinite(size).all() or ((size > 0) & (np.abs(roots.real) <= UNDAMPED * size)).any():
            return None
        numerator, denominator = poly(form.zeros), poly(form.poles)
        closed = _closed_loop_poles(form.gain.real * numerator, denominator)
        return None if closed is None else LoopLevels(form, closed, numerator, denominator)

    def terms(self, w: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """GH, u = d log GH / ds and du/ds at s = j w (`engine.model.paired_product`)."""
        terms = self.form.product.terms(1j * w, curvature=True)
        return terms.value, terms.slope, terms.curvature

    def slopes(self, w: NDArray) -> tuple[NDArray, NDArray]:
        """Rows: each level's derivative in omega and its own derivative, for
        the stationary points of log|GH|, arg GH and log|1 + GH|, then
        the levels log|GH| and Im GH themselves with their derivatives (the
        crossings): Newton's step on row k is first[k] / second[k]."""
        gh, u, du = self.terms(w)
        g = gh * u / (1.0 + gh)  # d log(1 + GH) / ds
        dg = gh * (u * u + du) / (1.0 + gh) - g * g
        first = np.array([-u.imag, u.real, -g.imag, np.log(np.abs(gh)), gh.imag])
        second = np.array([-du.real, -du.imag, -dg.real, -u.imag, (gh * u).real])
        return first, second

    def slopes_and_noise(self, w: NDArray) -> tuple[NDArray, NDArray]:
        """The first three rows of `slopes` (the stationary points' levels) and of
        `slope_noise` at ``w``, from one evaluation of the terms (the certificate
        reads both at its check points)."""
        terms = self.form.product.terms(1j * w, size=True)
        gh, u = terms.value, terms.slope
        g = gh * u / (1.0 + gh)  # as `slopes` forms it: the same bits
        return np.array([-u.imag, u.real, -g.imag]), _noise_rows(gh, self._u_noise(terms))

    def u_rounding(self, w: NDArray) -> tuple[NDArray, NDArray]:
        """GH at s = j w and the rounding of u there: a few ulp of the sum of its
        terms' sizes, and per root of |u| (each factor's relative error)."""
        terms = self.form.product.terms(1j * w, size=True)
        return terms.value, self._u_noise(terms)

    def _u_noise(self, terms: ProductTerms) -> NDArray:
        """The rounding of u = d log GH / ds from its terms (`u_rounding`)."""
        return ROUNDING * (terms.size + self.roots.size * np.abs(terms.slope))

    def slope_noise(self, w: NDArray) -> NDArray:
        """Rows: the rounding of the first three rows of `slopes` at ``w``: below it
        a slope's sign is not known.  Each is a part of a complex number (u, or
        g = GH u / (1 + GH)) whose every factor carries a relative error of a few
        ulp per root: its part's error is that times the number's size."""
        return _noise_rows(*self.u_rounding(w))

    def phase(self, w: NDArray) -> NDArray:
        """arg GH(j w), continuous in w > 0 (each root's angle on its own branch)."""
        return self.phase_offset + self.phase_turn @ np.arctan2(w - self.imag, self.damping)

    def values(self, w: NDArray) -> NDArray:
        """Rows: log|GH|, arg GH (continuous) and log|1 + GH| at ``w`` (the last from
        GH itself where it is small: 1 + GH would round its variation away)."""
        gh = self.terms(w)[0]
        with np.errstate(all="ignore"):
            return np.array([np.log(np.abs(gh)), self.phase(w), log_distance(gh)])

    @cached_property
    def fractions(self) -> Fractions:
        """The pencil of sums over t = -r**2, the slopes of log|GH| and arg GH in x = omega**2."""
        return Fractions(-(self.roots**2))

    @cached_property
    def slope_weights(self) -> dict[str, NDArray | None]:
        """The `Fractions.weights` of the slopes of log|GH| ("GH") and arg GH ("phase")
        over `fractions`; None for a level whose slope vanishes identically."""
        return {
            "GH": self.fractions.weights(self.signs.astype(complex)),
            "phase": self.fractions.weights(-self.signs * self.roots),
        }

    @cached_property
    def constant(self) -> frozenset[str]:
        """Levels constant at every frequency: "GH" (|GH|: an all-pass shape) and "phase"
        (arg GH: every root at 0, or roots mirrored across the imaginary axis)."""
        return frozenset(name for name, weights in self.slope_weights.items() if weights is None)

    @cached_property
    def sample(self) -> complex:
        """GH at the loop's scale frequency (the value of a constant level)."""
        return complex(self.terms(np.array([self.scale]))[0][0])

    @cached_property
    def distance_starts(self) -> NDArray | None:
        """`distance_stationary` of this loop (the margins' and the peaks' searches share it)."""
        return distance_stationary(self)

    @cached_property
    def all_limits(self) -> list[tuple[float, float]]:
        """The limits of `values`' rows at 0 and at infinity."""
        mag, phase = self.limits
        ends = []
        for level, turn in ((mag[0], phase[0]), (mag[1], phase[1])):
            if level == math.inf:
                ends.append(math.inf)
            elif level == -math.inf:
                ends.append(0.0)
            elif level > 700.0:  # |GH| beyond the floating-point range: log|1 + GH| is log|GH|
                ends.append(level)
            else:  # GH there is real: its magnitude and the sign its phase gives
                real = math.copysign(math.exp(level), math.cos(turn))
                ends.append(math.log(abs(1.0 + real)) if real != -1.0 else -math.inf)
        return [mag, phase, (ends[0], ends[1])]

    @cached_property
    def limits(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """(log|GH|, arg GH) as omega -> 0 and as omega -> infinity."""
        n0, excess, rest = self.asymptotes
        mag = (-math.inf * n0 if n0 else rest, math.inf * excess if excess else math.log(abs(self.gain)))
        top = (math.pi if self.gain < 0 else 0.0) + math.pi / 2 * excess
        zero = float(self.phase(np.zeros(1))[0]) + math.pi / 2 * n0  # atan2(0, 0) is 0, the limit pi/2
        return mag, (zero, top)


def _noise_rows(gh: NDArray, u_noise: NDArray) -> NDArray:
    """`LoopLevels.slope_noise`'s rows from GH and the rounding of u."""
    return np.array([u_noise, u_noise, np.abs(gh / (1.0 + gh)) * u_noise])


def log_distance(gh: NDArray) -> NDArray:
    """log |1 + GH|, from GH itself where |GH| is small (1 + GH would round its variation away)."""
    return np.where(
        np.abs(gh) < 0.5, 0.5 * np.log1p(2.0 * gh.real + (gh * gh.conjugate()).real), np.log(np.abs(1.0 + gh))
    )


def _closed_loop_poles(numerator: NDArray, denominator: NDArray) -> NDArray | None:
    """Zeros of 1 + GH: roots of D + k N (candidates only: every point found is polished on GH)."""
    char = polynomial_sum(denominator, numerator)
    if not np.isfinite(char).all():
        return None
    return roots(char)


def distance_stationary(loop: LoopLevels) -> NDArray | None:
    """The stationary points (in x) of log |1 + GH|^2 = log(1 + h), h = 2 Re GH +
    |GH|^2 = R(x) / P(x), P = prod (x + p^2) over the poles: the zeros of h' =
    -sum b_j / (x - t_j)^2, t_j = -p_j^2, with residues b_j = R(t_j) / P'(t_j) =
    k N(p_j) (D + k N)(-p_j) / prod_(i != j) (p_i^2 - p_j^2), all products of
    root differences.  h is built from GH itself, so a stationary point where
    |GH| is tiny (|1 + GH| = 1 to 1e-20 far above the crossover) is as sharp as
    any.  With repeated poles or an improper loop, the sum over the closed-loop
    poles c: sum 1/(x + c^2) - sum 1/(x + p^2), which cancels where c ~ p.
    Each form loses digits where the other does not (large residues that
    cancel, near clustered poles), so the starts are the zeros of both."""
    p, z, k = loop.form.poles, loop.form.zeros, loop.gain
    both = np.concatenate([loop.closed, p])
    weights = np.concatenate([np.ones(loop.closed.size), -np.ones(p.size)]).astype(complex)
    closed_form = Fractions(-(both**2)).zeros(weights)
    t = -(p**2)
    gaps = t[None, :] - t[:, None]
    np.fill_diagonal(gaps, 1.0)
    if z.size >= p.size or not np.abs(gaps).min(initial=np.inf) > 1e-8 * (float(np.abs(t).max()) or 1.0):
        return closed_form
    numerator = np.prod(p[:, None] - z[None, :], axis=1)
    closed = np.prod(-p[:, None] - p[None, :], axis=1) + k * np.prod(-p[:, None] - z[None, :], axis=1)
    residue_form = Fractions(t).zeros(k * numerator * closed / np.prod(gaps, axis=0), squared=True)
    forms = [x for x in (closed_form, residue_form) if x is not None]
    return np.concatenate(forms) if forms else None

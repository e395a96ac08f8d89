"""Closed-loop poles of one typed expression to full accuracy (against
mpmath's polyroots at 60 digits), common factors cancelled, and algebraic
loops judged by a relative pivot test."""

from __future__ import annotations

import warnings

import mpmath
import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback
from engine.errors import InterconnectionError

mpmath.mp.dps = 60


def _random_factors(rng: np.random.Generator, order: int) -> tuple[str, list, list, float]:
    """A loop K * prod(zero factors) / prod(pole factors) written as one
    expression: first- and second-order factors, time constants 1e-3..1e2,
    light damping, some right-half-plane roots; returns the text, the
    factors' (ascending) coefficient lists and K."""

    def factor(k: int) -> tuple[str, list[float]]:
        wn = float(10 ** rng.uniform(-3, 2))
        if k == 2:
            zeta = float(rng.choice([0.005, 0.05, 0.3, 0.8, -0.05]))
            return f"(s^2+{2 * zeta * wn!r}*s+{wn * wn!r})", [wn * wn, 2 * zeta * wn, 1.0]
        sign = -1.0 if rng.random() < 0.15 else 1.0
        return f"(s+{sign * wn!r})", [sign * wn, 1.0]

    poles, zeros, degree = [], [], 0
    while degree < order:
        k = 2 if order - degree >= 2 and rng.random() < 0.5 else 1
        poles.append(factor(k))
        degree += k
    zero_degree = int(rng.integers(0, order))
    d = 0
    while d < zero_degree:
        k = 2 if zero_degree - d >= 2 and rng.random() < 0.5 else 1
        zeros.append(factor(k))
        d += k
    gain = float(10 ** rng.uniform(-2, 2))
    num = "*".join(t for t, _ in zeros) or "1"
    den = "*".join(t for t, _ in poles)
    return f"{gain!r}*{num}/({den})", [c for _, c in zeros], [c for _, c in poles], gain


def _reference_poles(zeros: list, poles: list, gain: float) -> list:
    """Roots of D + K N at 60 digits (ascending coefficient lists multiplied out exactly)."""

    def product(factors: list) -> list:
        out = [mpmath.mpf(1)]
        for f in factors:
            new = [mpmath.mpf(0)] * (len(out) + len(f) - 1)
            for i, a in enumerate(out):
                for j, b in enumerate(f):
                    new[i + j] += a * mpmath.mpf(b)
            out = new
        return out

    n, d = product(zeros), product(poles)
    char = [d[i] + (mpmath.mpf(gain) * n[i] if i < len(n) else 0) for i in range(len(d))]
    with warnings.catch_warnings():  # mpmath 1.4 prefers asc=True, which 1.3 does not know
        warnings.simplefilter("ignore", DeprecationWarning)
        return mpmath.polyroots(char[::-1], maxsteps=400, extraprec=400)


@pytest.mark.parametrize("seed", range(12))
def test_closed_loop_poles_of_one_high_order_expression_match_60_digit_roots(seed):
    rng = np.random.default_rng(1000 + seed)
    text, zeros, poles, gain = _random_factors(rng, int(rng.integers(10, 21)))
    found = np.array(
        [p.value for p in analyze(unity_feedback([text]), "e", np.geomspace(1e-3, 1e3, 50), {}).closed_loop_poles]
    )
    reference = np.array([complex(r) for r in _reference_poles(zeros, poles, gain)])
    assert found.size == reference.size
    for r in reference:  # each true pole has a computed one within 1e-8 relative
        assert np.min(np.abs(found - r)) <= 1e-8 * abs(r), (text, r)


def test_w_plane_loop_typed_through_the_bilinear_map_is_stable():
    """H(z) = 0.2 (z + 0.5)/((z - 1)(z - 0.5)) at z = (1 + w)/(1 - w): the
    (1 - w) factors cancel; z-domain char. polynomial z^2 - 1.3 z + 0.6 has
    |z|^2 = 0.6 < 1 (stable)."""
    z = "((1+w)/(1-w))"
    a = analyze(unity_feedback([f"0.2*({z}+0.5)/(({z}-1)*({z}-0.5))"], "w"), "e", np.geomspace(1e-3, 1e3, 50), {})
    assert a.verdict == "stable"
    w_poles = np.array([p.value for p in a.closed_loop_poles])
    z_poles = (1 + w_poles) / (1 - w_poles)
    np.testing.assert_allclose(np.sort(np.abs(z_poles)), [np.sqrt(0.6)] * 2, rtol=1e-12)


def test_a_chain_of_extreme_gains_is_not_a_singular_algebraic_loop():
    """Gains from 3e-20 to 1e11 in series: 1 + GH(inf) = 1 + 3e-20 * 1e11 *
    1e11 * 2.59e-2 = 8.77, far from singular."""
    a = analyze(unity_feedback(["3e-20", "1e11", "1e11", "2.59e-2"]), "e", np.geomspace(1e-3, 1e3, 20), {})
    assert a.verdict == "stable" and a.closed_loop_poles == ()
    for singular in (["-1"], ["-1e-20", "1e20"]):  # loop gain exactly -1: 1 + GH(inf) = 0
        with pytest.raises(InterconnectionError, match="singular"):
            analyze(unity_feedback(singular), "e", np.geomspace(1e-3, 1e3, 20), {})

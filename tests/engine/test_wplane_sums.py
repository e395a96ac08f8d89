"""w-plane loops written with sums in Z = (1 + w)/(1 - w) (issue 35, section 2): a sum's terms
share their poles at w = 1, so the sum has them once; over the product of the terms'
denominators it had an extra pole-zero pair at w = 1 that no longer cancelled (a stable loop
called unstable).  The reference: the closed loop D(z) + K N(z) in exact rational arithmetic,
its roots by mpmath, mapped to w = (z - 1)/(z + 1)."""

from __future__ import annotations

from fractions import Fraction

import mpmath
import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback

Z = "((1+w)/(1-w))"
OMEGA = np.logspace(-3, 3, 300)


def _product(polys: list[list[Fraction]]) -> list[Fraction]:
    out = [Fraction(1)]
    for p in polys:
        out = [
            sum((out[i] * p[k - i] for i in range(len(out)) if 0 <= k - i < len(p)), Fraction(0))
            for k in range(len(out) + len(p) - 1)
        ]
    return out


def _random_loop(rng: np.random.Generator) -> tuple[str, list[Fraction]]:
    """K N(Z)/D(Z) with first-order factors (Z - a) and quadratics written as sums
    Z**2 + b Z + c; returns the text and D + K N (descending, exact)."""

    def factor() -> tuple[str, list[Fraction]]:
        if rng.random() < 0.5:
            a = f"{rng.uniform(-0.9, 0.9):.4f}"
            return f"({Z}-({a}))", [Fraction(1), -Fraction(a)]
        b, c = (f"{x:.4f}" for x in rng.uniform(-0.8, 0.8, 2))
        return f"({Z}**2+({b})*{Z}+({c}))", [Fraction(1), Fraction(b), Fraction(c)]

    den = [factor() for _ in range(int(rng.integers(1, 4)))]
    num = [factor() for _ in range(int(rng.integers(0, len(den))))]
    while sum(len(c) - 1 for _, c in num) > sum(len(c) - 1 for _, c in den):
        num.pop()
    gain = f"{10 ** rng.uniform(-1.5, 0.5):.4f}"
    text = f"{gain}*" + "*".join([t for t, _ in num] or ["1"]) + "/(" + "*".join(t for t, _ in den) + ")"
    d, n = _product([c for _, c in den]), [Fraction(gain) * x for x in _product([c for _, c in num])]
    n = [Fraction(0)] * (len(d) - len(n)) + n
    return text, [a + b for a, b in zip(d, n)]


def _exact_w_poles(characteristic: list[Fraction]) -> np.ndarray:
    mpmath.mp.dps = 50
    ascending = [mpmath.mpf(c.numerator) / c.denominator for c in reversed(characteristic)]
    z = mpmath.polyroots(ascending, maxsteps=500, extraprec=200, asc=True)
    return np.array([complex((r - 1) / (r + 1)) for r in z])


def test_the_issue_loop_is_stable() -> None:
    """0.3/(Z^2 - 0.5 Z + 0.1): the closed loop z^2 - 0.5 z + 0.4 has |z| = 0.632."""
    a = analyze(unity_feedback([f"0.3/({Z}**2-0.5*{Z}+0.1)"], variable="w"), "e", OMEGA, {})
    exact = _exact_w_poles([Fraction(1), Fraction(-1, 2), Fraction(2, 5)])
    assert a.verdict == "stable"
    got = np.sort_complex(np.array([p.value for p in a.closed_loop_poles]))
    assert np.allclose(got, np.sort_complex(exact), rtol=1e-12, atol=0)


@pytest.mark.parametrize("seed", range(4))
def test_random_sums_and_products_in_z(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    for _ in range(25):
        text, characteristic = _random_loop(rng)
        exact = _exact_w_poles(characteristic)
        a = analyze(unity_feedback([text], variable="w"), "e", OMEGA, {})
        got = np.array([p.value for p in a.closed_loop_poles])
        assert got.size == exact.size, text
        for g in got:
            assert np.min(np.abs(exact - g)) <= 1e-8 * max(1.0, abs(g)), text
        assert (a.verdict == "stable") == bool(np.all(exact.real < 0)), text

"""Bracketed roots of many functions at once (`engine.numerics.bracketing`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.numerics.bracketing import bracketed_roots


def test_each_root_has_its_own_function():
    # h_k(w) = log w - c_k: roots e^c_k, three brackets of different widths (a regression: the ends
    # of all brackets were once evaluated in one call, against the wrong c_k)
    c = np.array([0.0, 1.0, 2.0])

    def fun(w, which):
        return np.log(w) - c[which], 1.0 / w

    found = bracketed_roots(fun, np.array([0.5, 1.0, 5.0]), np.array([2.0, 5.0, 10.0]))
    np.testing.assert_allclose(found, np.exp(c), rtol=4e-16)


def test_a_steep_power_law_does_not_crawl():
    # h(w) = w^-8 - 1e-16 over twelve decades, root 1e2: from the left Newton's step in log w is
    # 1/8 (it would crawl ~40 steps), the secant's values differ by 64 orders of magnitude; with the
    # bisection of a stalled bracket it takes 33 evaluations (measured; bisection alone: ~55)
    calls = []

    def fun(w, which):
        calls.append(w.size)
        return w**-8.0 - 1e-16, -8.0 * w**-9.0

    (root,) = bracketed_roots(fun, np.array([1e-6]), np.array([1e6]))
    assert root == pytest.approx(100.0, rel=4e-15)
    assert len(calls) <= 40


def test_a_root_at_an_end_and_an_empty_request():
    (root,) = bracketed_roots(lambda w, which: (w - 2.0, np.ones_like(w)), np.array([2.0]), np.array([3.0]))
    assert root == 2.0
    assert bracketed_roots(lambda w, which: (w, w), np.zeros(0), np.zeros(0)).size == 0


def test_a_flat_root_stops_at_its_rounding_noise():
    # h(w) = (w - 1)^3: a triple root, which no method resolves beyond ~eps^(1/3); the search
    # stops (steps that stop shrinking below 1e-9) instead of running out of steps
    (root,) = bracketed_roots(lambda w, which: ((w - 1.0) ** 3, 3 * (w - 1.0) ** 2), np.array([0.5]), np.array([3.0]))
    assert abs(root - 1.0) < 1e-5 and math.isfinite(root)


def _counted(fun):
    calls = []

    def counting(w, which=None):
        calls.append(w.size)
        return fun(w)

    return counting, calls


def test_a_newton_step_below_one_ulp_ends_the_search():
    # h(w) = c (w - R): near R Newton's step in log w is |w - R| / R, a few 1e-16, less than half
    # an ulp of log R (4.4e-16 to 8.9e-16 for R in 10..1000), so it rounds onto the bracket's end.
    # Taken as outside the bracket it fell to a secant step 2 % of the bracket away: up to 19
    # evaluations over these 200 (measured before the fix), 11 with it
    rng = np.random.default_rng(2)
    worst = 0
    for _ in range(200):
        root, scale = 10 ** rng.uniform(1, 3), 10 ** rng.uniform(-40, 0)
        fun, calls = _counted(lambda w, r=root, c=scale: (c * (w - r), np.full_like(w, c)))
        (found,) = bracketed_roots(
            fun, np.array([root / rng.uniform(1.01, 100)]), np.array([root * rng.uniform(1.01, 100)])
        )
        assert found == pytest.approx(root, rel=4 * np.finfo(float).eps)
        worst = max(worst, len(calls))
    assert worst <= 12


def test_a_root_flat_to_rounding_stops_within_its_noise_bound():
    # h(w) = 1e-20 (log w - log r) plus rounding noise of 1e-26 (a slope of |T| far below the
    # crossover: the root is determined to ~1e-6 only): with the noise bound the search stops
    # once its steps stop shrinking inside the noise, without it it bisects the noise down to
    # 4 ulp (some 30 steps)
    r = 6.82e-5

    def fun(w):
        return 1e-20 * (np.log(w) - math.log(r)) + 1e-26 * np.sin(1e9 * w / r), 1e-20 / w

    quiet, calls = _counted(fun)
    (found,) = bracketed_roots(quiet, np.array([5e-5]), np.array([1.6e-4]), noise=lambda w: np.full_like(w, 1e-24))
    assert abs(math.log(found / r)) < 1e-5
    assert len(calls) <= 12
    noisy, calls = _counted(fun)
    (found,) = bracketed_roots(noisy, np.array([5e-5]), np.array([1.6e-4]))
    assert abs(math.log(found / r)) < 1e-5

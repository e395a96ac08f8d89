"""The bracketed refinement behind the margins, on functions with known roots."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.numerics.refinement import refine


def _levels(functions):
    """fun(points, which) for one (h, h') pair per bracket."""

    def fun(points, which):
        h, d = np.empty(points.size), np.empty(points.size)
        for i, (x, k) in enumerate(zip(points, which)):
            h[i], d[i] = functions[k](x)
        return h, d

    return fun


def _ends(functions, a, b):
    ha, da = zip(*(f(x) for f, x in zip(functions, a)))
    hb, db = zip(*(f(x) for f, x in zip(functions, b)))
    return np.array(ha), np.array(hb), np.array(da), np.array(db)


def test_crossings_and_extrema_to_a_few_ulp():
    """Roots of x^3 - 2 and of cos x (sign change at pi/2), the minimum of
    (x - e)^2 + 1 and the maximum of sin x at pi/2: closed-form answers."""
    crossings = [lambda x: (x**3 - 2.0, 3 * x**2), lambda x: (math.cos(x), -math.sin(x))]
    a, b = np.array([1.0, 1.0]), np.array([2.0, 3.0])
    roots = refine(_levels(crossings), a, b, *_ends(crossings, a, b), stationary=False).at
    np.testing.assert_allclose(roots, [2.0 ** (1 / 3), math.pi / 2], rtol=8 * np.finfo(float).eps)
    extrema = [lambda x: ((x - math.e) ** 2 + 1.0, 2 * (x - math.e)), lambda x: (math.sin(x), math.cos(x))]
    a, b = np.array([2.0, 1.0]), np.array([3.0, 3.0])
    roots = refine(_levels(extrema), a, b, *_ends(extrema, a, b), stationary=True).at
    np.testing.assert_allclose(roots, [math.e, math.pi / 2], rtol=8 * np.finfo(float).eps)


def test_an_exact_zero_at_an_end_or_on_the_way_is_the_root():
    f = [lambda x: (x - 1.0, 1.0), lambda x: (x - 1.5, 1.0)]
    a, b = np.array([1.0, 1.0]), np.array([2.0, 2.0])
    assert list(refine(_levels(f), a, b, *_ends(f, a, b), stationary=False).at) == [1.0, 1.5]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3, unique=True))
def test_a_cubic_root_between_its_neighbours(roots):
    """h = (x - r1)(x - r2)(x - r3): bracket each root by the midpoints to its
    neighbours; every root is found to 1e-12 whatever the curvature."""
    r = np.sort(roots)
    if np.min(np.diff(r)) < 0.05:
        return
    poly = np.poly(r)
    f = lambda x: (np.polyval(poly, x), np.polyval(np.polyder(poly), x))  # noqa: E731
    edges = np.concatenate([[r[0] - 1.0], 0.5 * (r[1:] + r[:-1]), [r[-1] + 1.0]])
    a, b = edges[:-1], edges[1:]
    found = refine(_levels([f] * 3), a, b, *_ends([f] * 3, a, b), stationary=False).at
    np.testing.assert_allclose(found, r, atol=1e-12)


def test_a_watched_extremum_reveals_the_two_crossings_beside_it():
    """h = 1 - (x - 2)^2 on [0.5, 3.5]: h = -1.25 at both ends, so no
    crossing shows there; the maximum at 2 lies across h = 0 and reveals the
    crossings at 1 and 3, refined in the same loop.  A bracket beside it
    (a plain crossing of x^2 - 2) is refined alongside, and
    h = (x - 2)^2 + 1 (its minimum does not reach 0) reveals nothing."""
    f = [
        lambda x: (1.0 - (x - 2.0) ** 2, -2.0 * (x - 2.0)),
        lambda x: ((x - 2.0) ** 2 + 1.0, 2.0 * (x - 2.0)),
        lambda x: (x * x - 2.0, 2.0 * x),
    ]
    a, b = np.array([0.5, 0.5, 1.0]), np.array([3.5, 3.5, 2.0])
    found = refine(
        _levels(f),
        a,
        b,
        *_ends(f, a, b),
        stationary=np.array([True, True, False]),
        hiding=np.array([True, True, False]),
    )
    eps = np.finfo(float).eps
    np.testing.assert_allclose(found.at, [2.0, 2.0, math.sqrt(2.0)], rtol=8 * eps)
    np.testing.assert_allclose(found.hidden[0], [1.0, 3.0], rtol=8 * eps)
    assert np.all(np.isnan(found.hidden[1:]))


def test_newton_takes_over_when_the_inverse_cubic_is_not_monotone():
    """h = atan(50 (x - 0.1)) on [0, 1]: steep at the root, flat at the far
    end (end slopes 10 and 0.02), so the inverse cubic through both ends
    bends far away (Fritsch-Carlson fails) and Newton from the better end
    steps instead.  The root 0.1 is found to a few ulp in at most 8
    evaluations (10 with the cubic taken blindly)."""
    calls = []

    def fun(points, which):
        calls.append(points.size)
        return np.arctan(50.0 * (points - 0.1)), 50.0 / (1.0 + (50.0 * (points - 0.1)) ** 2)

    a, b = np.array([0.0]), np.array([1.0])
    h, d = fun(np.concatenate([a, b]), None)
    calls.clear()
    found = refine(fun, a, b, h[:1], h[1:], d[:1], d[1:], stationary=False).at
    np.testing.assert_allclose(found, [0.1], rtol=8 * np.finfo(float).eps)
    assert len(calls) <= 8


def test_jobs_refined_together_give_what_each_gives_alone():
    """`refine_together`: the watched maximum of 1 - (x - 2)^2 (revealing 1 and 3) and a crossing of
    x^2 - 2 in one job, the extrema of sin x and (x - e)^2 + 1 in another: every root, hidden crossing
    and bound count is `refine`'s for that job alone, to the bit; with 3 rounds, the bound bites
    in both, each job counting its own brackets."""
    from engine.numerics.refinement import Job, refine_together

    first = [
        lambda x: (1.0 - (x - 2.0) ** 2, -2.0 * (x - 2.0)),
        lambda x: (x * x - 2.0, 2.0 * x),
    ]
    second = [lambda x: (math.sin(x), math.cos(x)), lambda x: ((x - math.e) ** 2 + 1.0, 2 * (x - math.e))]
    a1, b1 = np.array([0.5, 1.0]), np.array([3.5, 2.0])
    a2, b2 = np.array([1.0, 2.0]), np.array([3.0, 3.0])
    jobs = [
        Job(_levels(first), a1, b1, *_ends(first, a1, b1), np.array([True, False]), np.array([True, False])),
        Job(_levels(second), a2, b2, *_ends(second, a2, b2), True),
    ]
    for rounds in (200, 3):
        together = refine_together(jobs, max_iter=rounds)
        for job, found in zip(jobs, together):
            alone = refine(*job, max_iter=rounds)
            np.testing.assert_array_equal(found.at, alone.at)
            np.testing.assert_array_equal(found.hidden, alone.hidden)
            assert found.bounded == alone.bounded and (found.bounded > 0) == (rounds == 3)
    np.testing.assert_allclose(refine_together(jobs)[0].hidden[0], [1.0, 3.0], rtol=8 * np.finfo(float).eps)

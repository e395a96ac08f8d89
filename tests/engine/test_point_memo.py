"""`PointMemo`: a function of frequency computed once per frequency, its values as the function's."""

from __future__ import annotations

import numpy as np

from engine.numerics.point_memo import MOST_POINTS, PointMemo


def _response(w):
    s = 1j * w
    return 1 / (s + 1), -1j / (s + 1) ** 2


def _counted(memo: PointMemo, asked: list[int]):
    return lambda w: memo.values(w, lambda x: asked.append(x.size) or _response(x))


def test_each_frequency_is_computed_once_and_reads_as_the_function():
    memo, asked = PointMemo(), []
    values = _counted(memo, asked)
    first = np.geomspace(0.1, 10, 50)
    values(first)
    mixed = np.array([[first[3], 42.0], [first[3], first[0]]])  # seen, new, repeated, unordered, 2-d
    got, slope = values(mixed)
    want, want_slope = _response(mixed)
    assert got.shape == mixed.shape and np.array_equal(got, want) and np.array_equal(slope, want_slope)
    assert asked == [50, 1]
    values(np.array([42.0, first[7]]))
    assert asked == [50, 1]


def test_the_memo_is_bounded_and_passes_non_finite_frequencies_through():
    memo, asked = PointMemo(), []
    values = _counted(memo, asked)
    values(np.arange(1.0, MOST_POINTS + 1))
    values(np.array([0.5]))  # past the bound: only this one kept
    values(np.array([2.0]))
    assert asked == [MOST_POINTS, 1, 1]
    got, _ = values(np.array([np.nan, 1.0]))
    assert np.isnan(got[0]) and got[1] == _response(np.array([1.0]))[0][0] and asked[-1] == 2

"""Peaks of |S|, |T| and the disk margin's |S + (sigma - 1)/2| found without
a grid (`engine.margins.pole_zero.peaks`): closed forms, limits at the ends, and agreement
with the grid search on random loops."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.loop.pole_zero import ZpkEvaluator
from engine.loop.responses import loop_model
from engine.margins import peaks
from engine.margins.disk import disk_transform
from engine.margins.pole_zero.peaks import moebius_peaks
from engine.margins.search import Band
from tests.engine.loopfactory import loop_network, random_loop

GRID = np.geomspace(1e-3, 1e3, 10)
TRANSFORMS = [peaks.sensitivity, peaks.complementary, disk_transform(0.0), disk_transform(0.7)]


def form_of(expression: str) -> ZpkEvaluator:
    return loop_model(unity_feedback([expression]), "e", GRID, {}).evaluate


def test_second_order_resonance_closed_form():
    # GH = 4/(s (s + 1)): T = 4/(s^2 + s + 4), wn = 2, zeta = 1/4:
    # Mt = 1/(2 zeta sqrt(1 - zeta^2)) at wn sqrt(1 - 2 zeta^2)
    ((mt, wr),) = moebius_peaks(form_of("4/(s*(s+1))"), [(0.0, 1.0)])
    zeta = 0.25
    assert mt == pytest.approx(1 / (2 * zeta * math.sqrt(1 - zeta**2)), rel=1e-14)
    assert wr == pytest.approx(2 * math.sqrt(1 - 2 * zeta**2), rel=1e-13)


def test_a_peak_at_an_end_is_the_limit_there():
    # GH = 0.5/(s + 1): S = (s + 1)/(s + 1.5) rises from 2/3 to 1 (at infinity); T falls from 1/3
    (s_peak, t_peak) = moebius_peaks(form_of("0.5/(s+1)"), [(1.0, 0.0), (0.0, 1.0)])
    assert s_peak == (1.0, math.inf)
    assert t_peak[1] == 0.0 and t_peak[0] == pytest.approx(1 / 3, rel=1e-15)
    # within a band the ends are evaluated: |S(j 2)| = |(1 + 2j)/(1.5 + 2j)|
    ((value, where),) = moebius_peaks(form_of("0.5/(s+1)"), [(1.0, 0.0)], 0.5, 2.0)
    assert where == 2.0 and value == pytest.approx(abs((1 + 2j) / (1.5 + 2j)), rel=1e-15)


def test_a_constant_transform_peaks_at_its_value():
    """The disk margin's (1 - GH)/(2 (1 + GH)) of K/s is all-pass (|f| = 1/2 at every
    frequency; its sum of fractions vanishes): no stationary point is searched, the
    peak is the value (at an end), and S and T of the same loop are still found:
    |S| = w/|jw + K| rises to 1 at infinity, |T| = K/|jw + K| falls from 1 at 0."""
    (disk, s_peak, t_peak) = moebius_peaks(form_of("79/s"), [(0.5, -0.5), (1.0, 0.0), (0.0, 1.0)])
    assert disk[0] == pytest.approx(0.5, rel=1e-15)
    assert s_peak == (1.0, math.inf) and t_peak == (1.0, 0.0)
    # a band: the constant's value at its ends
    ((value, where),) = moebius_peaks(form_of("79/s"), [(0.5, -0.5)], 2.0, 3.0)
    assert value == pytest.approx(0.5, rel=1e-15) and where in (2.0, 3.0)


def test_a_shallow_peak_the_detection_grid_misses():
    """K/s**3 times an all-pass factor (found checking the constant-level loops against the grid).
    Mt is a shallow maximum (1.0000124 near 0.051 rad/s, which the detection grid
    missed, reporting 1 at 0): the grid-free peaks equal a dense sampling's."""
    k, a = 0.01855649930790591, 19.19205673142937
    ((mt, where),) = moebius_peaks(form_of(f"{k!r}/s**3*(s - {a!r})/(s + {a!r})"), [(0.0, 1.0)])
    w = np.geomspace(0.03, 0.08, 200_001)
    gh = k / (1j * w) ** 3 * (1j * w - a) / (1j * w + a)
    dense = np.abs(gh / (1 + gh))
    assert mt == pytest.approx(dense.max(), rel=1e-12) and mt > 1.00001
    assert where == pytest.approx(w[np.argmax(dense)], rel=1e-4)


def test_a_degenerate_loop_is_left_to_the_grid(monkeypatch):
    """GH = 3/s**2 lies on the negative real axis at every frequency: its closed loop
    has poles at +-j sqrt(3), where |S| and |T| are infinite.  The grid-free search
    does not try (it chased that pole through five rounds of repairs, 0.1 s)."""

    def searched(*args):
        raise AssertionError("the stationary points of a degenerate loop were searched")

    monkeypatch.setattr("engine.margins.pole_zero.peaks._stationary", searched)
    assert moebius_peaks(form_of("3/s**2"), [t.moebius for t in TRANSFORMS]) is None


@pytest.mark.long
@pytest.mark.slow
def test_random_loops_agree_with_the_grid_search():
    """200 random loops of order 1..12: Ms, Mt and two disk peaks equal the
    grid search's to 1e-12 (values) and 1e-7 (frequencies: a peak is flat,
    its place is known to about the square root of the precision)."""
    answered = 0
    for seed in range(200):
        num, den = random_loop(seed)
        loop = loop_model(loop_network(num, den), "e", GRID, {})
        if not isinstance(loop.evaluate, ZpkEvaluator):
            continue
        fast = moebius_peaks(loop.evaluate, [t.moebius for t in TRANSFORMS])
        if fast is None:
            continue
        answered += 1
        for grid, (value, frequency) in zip(peaks._peaks_on(loop, TRANSFORMS, Band()), fast):
            assert value == pytest.approx(grid.value, rel=1e-12), seed
            if 0 < frequency < math.inf and 0 < grid.frequency < math.inf:
                assert frequency == pytest.approx(grid.frequency, rel=1e-7), seed
            # else a limit at an end, which the grid may equal to the last digit at its last point
    assert answered >= 190  # measured: 199


HIGH_GAIN_ORDER_20 = (
    "*(s+1)*(s+3)*(s**2+0.2*s+9)/(s*(s+0.5)*(s+2)*(s+5)*(s+10)*(s**2+0.4*s+4)*(s**2+2*s+50)"
    "*(s+40)*(s**2+0.1*s+25)*(s**2+0.3*s+100)*(s+60)*(s+80)*(s**2+3*s+400)*(s+200)*(s+300))"
)


@pytest.mark.parametrize("step", range(8))
def test_levels_flat_to_rounding_do_not_stop_the_search(step):
    """A type-1 loop of order 20 with a large gain: far below its crossover |S|
    is 0 to 1e-10 and the disk's |S - 1/2| is 1/2 to 1e-10, their slopes
    rounding.  Their signs there are unknown, not contradictions to repair
    (before, half of these loops, their gains a few ulp apart, exhausted the
    repairs and fell back to the grid); the peaks equal the grid search's."""
    loop = loop_model(unity_feedback([f"{1e3 * (1 + 1e-12 * step)!r}{HIGH_GAIN_ORDER_20}"]), "e", GRID, {})
    fast = moebius_peaks(loop.evaluate, [t.moebius for t in TRANSFORMS])
    assert fast is not None
    for transform, grid, (value, frequency) in zip(TRANSFORMS, peaks._peaks_on(loop, TRANSFORMS, Band()), fast):
        assert value == pytest.approx(grid.value, rel=1e-12)
        if 0 < frequency < math.inf and 0 < grid.frequency < math.inf and resolved(loop, transform, frequency):
            assert frequency == pytest.approx(grid.frequency, rel=1e-7)


def resolved(loop, transform, frequency: float) -> bool:
    """Is |f| 1e-3 away from its peak lower by more than rounding (else the peak's
    place is not determined by |f|'s values, and a grid search cannot find it:
    |S| of this loop peaks at 1 + 4e-16)?"""
    a, b = transform.moebius
    gh = loop.evaluate(np.array([frequency, frequency * 0.999, frequency * 1.001]))[0]
    level = np.abs((a + b * gh) / (1 + gh))
    return bool(level[0] - level[1:].max() > 1e-13 * level[0])


@pytest.mark.long
@pytest.mark.slow
def test_the_peak_of_s_after_a_margin_search_is_the_one_searched_alone():
    """After the margin search of a form, a multiple of S takes its stationary points
    (those of |1 + GH|, certified there) instead of searching them again: the same
    peaks as a fresh form's own search, on 200 random loops."""
    from engine.margins.pole_zero.levels import LoopLevels
    from engine.margins.pole_zero.search import fast_margins

    reused = 0
    ab = [t.moebius for t in TRANSFORMS] + [(2.5, 0.0)]
    for seed in range(200):
        num, den = random_loop(seed)
        fresh, searched = (loop_model(loop_network(num, den), "e", GRID, {}).evaluate for _ in range(2))
        if not isinstance(fresh, ZpkEvaluator) or fast_margins(searched) is None:
            continue
        assert (
            LoopLevels.of(searched).certified_distance is not None and LoopLevels.of(fresh).certified_distance is None
        )
        alone, after = moebius_peaks(fresh, ab), moebius_peaks(searched, ab)
        if alone is None:
            continue
        reused += 1
        for (value, frequency), (again, where) in zip(alone, after):
            assert again == pytest.approx(value, rel=1e-13) and (
                where == frequency or where == pytest.approx(frequency, rel=1e-9)
            ), seed
    assert reused >= 180


SIX_LIGHT_MODES = (
    "1e4*(s+1)/(s*(s+0.1)*(s+10)*(s+100)*(s**2+0.002*s+25)*(s**2+0.004*s+100)*(s**2+0.006*s+400)"
    "*(s**2+0.008*s+900)*(s**2+0.01*s+1600)*(s**2+0.01*s+2500)*(s**2+0.01*s+3600))"
)


def test_the_disk_peak_by_light_modes_starts_where_the_distance_is_stationary(monkeypatch):
    """Near lightly damped modes the disk transform's own sums cancel and its
    stationary points were missed, each bracketed by the certificate (five on
    this loop, 25 evaluations); it now starts from |1 + GH|'s as well, and
    after the margin search needs no repair.  The peaks equal the grid's."""
    from engine.margins.pole_zero import certificate as zpk_certify
    from engine.margins.pole_zero.search import fast_margins

    repaired = []
    real = zpk_certify._repaired
    monkeypatch.setattr(
        zpk_certify,
        "_repaired",
        lambda slopes, row, *rest, **kw: repaired.append(row) or real(slopes, row, *rest, **kw),
    )
    loop = loop_model(unity_feedback([SIX_LIGHT_MODES]), "e", GRID, {})
    assert fast_margins(loop.evaluate) is not None
    repaired.clear()
    transforms = [disk_transform(0.0), peaks.sensitivity, peaks.complementary]
    fast = moebius_peaks(loop.evaluate, [t.moebius for t in transforms])
    assert fast is not None and repaired == []
    for grid, (value, _frequency) in zip(peaks._peaks_on(loop, transforms, Band()), fast):
        assert value == pytest.approx(grid.value, rel=1e-12)

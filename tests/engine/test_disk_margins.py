"""Disk margins: against python-control's `disk_margins` on a very dense grid
around the worst frequency (python-control samples the grid it is given, so
it agrees to the grid's resolution, here better than 1e-6), and against a
brute-force maximum written here (dense sampling, then golden-section search
in mpmath) to 1e-10."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback
from engine.errors import EngineError
from engine.loop.realization import poles, realize, stability
from engine.loop.responses import loop_model
from engine.margins.disk import disk_gain_phase, disk_margin
from tests.engine.loopfactory import loop_network, random_loop
from tests.engine.test_sensitivity import _mp_loop, reference_peak

GRID = np.geomspace(1e-3, 1e3, 10)


def _stable_seeds(count: int) -> list[int]:
    seeds, seed = [], 0
    while len(seeds) < count:
        num, den = random_loop(seed)
        if stability(poles(realize(loop_network(num, den), {}))) == "stable":
            seeds.append(seed)
        seed += 1
    return seeds


@pytest.mark.parametrize("seed", _stable_seeds(20))
@pytest.mark.parametrize("skew", [0.0, 0.6, -0.5])
def test_disk_margins_match_python_control_and_a_brute_force_maximum(seed, skew):
    num, den = random_loop(seed)
    d = disk_margin(loop_model(loop_network(num, den), "e", GRID, {}), skew, stable=True)
    shift = 0.5 * (skew - 1)
    peak, w0, interior = reference_peak(
        lambda w: np.abs(1 / (1 + np.polyval(num, 1j * w) / np.polyval(den, 1j * w)) + shift),
        lambda x: abs(1 / (1 + _mp_loop(num, den, x)) + shift),
        1e-5,
        1e6,
    )
    if not interior:
        pytest.skip("the worst disk is at an end of the frequency axis (closed-form tests cover it)")
    assert d.alpha == pytest.approx(1 / peak, rel=1e-10)
    # python-control on 20001 points within 0.1 % of the worst frequency
    w = np.geomspace(w0 * 0.999, w0 * 1.001, 20001)
    dm, dgm, dpm = control.disk_margins(control.tf(num, den), w, skew=skew)
    assert d.alpha == pytest.approx(dm, rel=1e-6) and d.alpha <= dm * (1 + 1e-12)  # a grid maximum is lower
    assert d.frequency == pytest.approx(w0, rel=1e-3)
    if math.isfinite(dgm):
        assert d.gain_db == pytest.approx(dgm, rel=1e-6)
    if math.isfinite(dpm):
        assert d.phase_deg == pytest.approx(dpm, rel=1e-6)


def test_balanced_disk_of_a_first_order_loop_is_at_infinity():
    # L = k/(s + 1): |S - 1/2| = |s + 1 - k|/(2 |s + 1 + k|) rises to 1/2 as w -> inf: alpha = 2
    d = disk_margin(loop_model(unity_feedback(["4/(s+1)"]), "e", GRID, {}), stable=True)
    assert d.alpha == pytest.approx(2.0, rel=1e-15) and d.frequency == math.inf
    assert d.gain_low == 0.0 and d.gain_high == math.inf and d.phase_deg == pytest.approx(90.0, rel=1e-12)


@pytest.mark.parametrize("alpha", [0.1, 0.5, 1.0, 1.9])
def test_balanced_disk_phase_is_two_atan_half_alpha(alpha):
    # skew 0: gamma_min = (1 - a)/(1 + a) = 1/gamma_max (a = alpha/2), phase = 2 atan(a)
    low, high, phase = disk_gain_phase(alpha, 0.0)
    a = alpha / 2
    assert low == pytest.approx((1 - a) / (1 + a), rel=1e-15) and high == pytest.approx(1 / low, rel=1e-14)
    assert phase == pytest.approx(math.degrees(2 * math.atan(a)), rel=1e-13)


def test_skew_one_is_the_sensitivity_disk():
    # skew 1: alpha = 1/max |S|, gamma_min = 1/(1 + alpha), gamma_max unbounded for alpha >= 1
    model = loop_model(unity_feedback(["9/(s*(s+1.2))"]), "e", GRID, {})
    d = disk_margin(model, 1.0, stable=True)
    ms, _, interior = reference_peak(
        lambda w: np.abs(1 / (1 + 9 / (1j * w * (1j * w + 1.2)))),
        lambda x: abs(1 / (1 + _mp_loop([9.0], [1.0, 1.2, 0.0], x))),
        1e-3,
        1e3,
    )
    assert interior and d.alpha == pytest.approx(1 / ms, rel=1e-12)
    assert d.gain_low == pytest.approx(1 / (1 + d.alpha), rel=1e-14)


def test_an_unstable_closed_loop_has_no_disk_margin():
    network = unity_feedback(["16000/(s*(s+8)*(s+20))"])
    a = analyze(network, "e", GRID, {})
    assert a.verdict == "unstable"
    d = a.disk_margin
    assert d.alpha == 0.0 and (d.gain_low, d.gain_high, d.phase_deg) == (1.0, 1.0, 0.0)
    assert any("unstable" in n for n in d.notes)
    # Ms is still the peak of |S|
    assert a.sensitivity_peak.value > 1


def test_unknown_stability_says_the_margin_assumes_it_and_bad_skews_are_refused():
    model = loop_model(unity_feedback(["2/(s*(s+1))*exp(-0.1*s)"]), "e", np.geomspace(1e-2, 1e2, 50), {})
    d = disk_margin(model)
    assert 0 < d.alpha < 2 and any("assumes a stable closed loop" in n for n in d.notes)
    for bad in (math.nan, math.inf, "x"):
        with pytest.raises(EngineError, match="skew"):
            disk_margin(model, bad)


def test_the_published_example_of_seiler_packard_gahinet():
    """Seiler, Packard, Gahinet, "An introduction to disk margins", IEEE Control
    Systems Magazine 40(5), 2020: L = 25/(s^3 + 10 s^2 + 10 s + 10) has the
    balanced disk margin alpha = 0.46, guaranteeing gains 0.63..1.59 and phase
    +-25.8 deg, its worst disk near 1.94 rad/s (the values as printed, to their
    digits; ControlSystems.jl's test of the example checks them to 0.02)."""
    d = disk_margin(loop_model(unity_feedback(["25/(s**3+10*s**2+10*s+10)"]), "e", GRID, {}), 0.0, stable=True)
    assert round(d.alpha, 2) == 0.46
    assert round(d.gain_low, 2) == 0.63 and round(d.gain_high, 2) == 1.59
    assert round(d.phase_deg, 1) == 25.8
    assert abs(d.frequency - 1.94) < 0.02

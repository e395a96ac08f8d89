"""Ms = max |S|, Mt = max |T| and max |K S| in a band, refined to exact extrema:
checked against an independent reference (dense sampling, then golden-section
search in 40-digit mpmath on the loop's own polynomial coefficients)."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.margins.peaks import (
    compensator_peak,
    complementary,
    complementary_peak,
    magnitude_curves,
    refined_peaks,
    sensitivity,
    sensitivity_peak,
)
from engine.margins.search import Band
from tests.engine.loopfactory import loop_network, random_loop, tabulated_loop

GRID = np.geomspace(1e-3, 1e3, 10)
mpmath.mp.dps = 40


def mp_poly(coefficients, s):
    """Horner's rule in mpmath on descending coefficients (exact doubles)."""
    out = mpmath.mpf(0)
    for c in coefficients:
        out = out * s + mpmath.mpf(float(c))
    return out


def _mp_loop(num, den, x):
    s = mpmath.mpc(0, x)
    return mp_poly(num, s) / mp_poly(den, s)


def golden_max(f, a: float, b: float, iterations: int = 140) -> mpmath.mpf:
    """max of f over [a, b] (one maximum inside) by golden-section search in mpmath."""
    a, b = mpmath.mpf(a), mpmath.mpf(b)
    r = (mpmath.sqrt(5) - 1) / 2
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iterations):
        if fc > fd:
            b, d, fd = d, c, fc
            c = b - r * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + r * (b - a)
            fd = f(d)
    return max(fc, fd)


def reference_peak(value_np, value_mp, low: float, high: float) -> tuple[float, float, bool]:
    """(peak, frequency, interior) by dense sampling over [low, high], refined in mpmath when interior."""
    w = np.geomspace(low, high, 200_001)
    v = value_np(w)
    i = int(np.argmax(v))
    if not low * 10 < w[i] < high / 10:  # at (or flat towards) an end of the axis
        return float(v[i]), float(w[i]), False
    return float(golden_max(value_mp, w[i - 1], w[i + 1])), float(w[i]), True


KINDS = {"S": (lambda L: 1 / (1 + L)), "T": (lambda L: L / (1 + L))}


@pytest.mark.parametrize("seed", range(30))
def test_peaks_of_random_loops_match_a_dense_refined_reference(seed):
    num, den = random_loop(seed)
    model = loop_model(loop_network(num, den), "e", GRID, {})
    found = dict(zip("ST", refined_peaks(model, [sensitivity, complementary])))
    for name, f in KINDS.items():
        peak, w0, interior = reference_peak(
            lambda w: np.abs(f(np.polyval(num, 1j * w) / np.polyval(den, 1j * w))),
            lambda x: abs(f(_mp_loop(num, den, x))),
            1e-5,
            1e6,
        )
        if not interior:  # the supremum is at an end (w -> 0 or inf): checked in the closed-form tests
            continue
        p = found[name]
        assert p.method == "refined"
        assert p.value == pytest.approx(peak, rel=1e-10), (name, p, peak, w0)
        assert p.value >= peak * (1 - 1e-12)  # never below the true maximum: it is the maximum


def test_closed_form_second_order_sensitivity_peaks():
    # L = wn^2/(s (s + 2 zeta wn)): T is the standard second-order system, Mt = 1/(2 zeta sqrt(1 - zeta^2))
    zeta, wn = 0.2, 3.0
    model = loop_model(unity_feedback([f"{wn**2}/(s*(s+{2 * zeta * wn}))"]), "e", GRID, {})
    mt = complementary_peak(model)
    assert mt.value == pytest.approx(1 / (2 * zeta * math.sqrt(1 - zeta**2)), rel=1e-13)
    assert mt.frequency == pytest.approx(wn * math.sqrt(1 - 2 * zeta**2), rel=1e-9)
    assert mt.db == pytest.approx(20 * math.log10(mt.value), rel=1e-15)


def test_a_supremum_at_infinity_is_the_limit():
    # L = 2/(s + 1): |S| = |s + 1|/|s + 3| rises to 1 as w -> inf, never attained
    p = sensitivity_peak(loop_model(unity_feedback(["2/(s+1)"]), "e", GRID, {}))
    assert p.frequency == math.inf and p.value == pytest.approx(1.0, rel=1e-15)
    # and T = 2/(s + 3) peaks at w = 0: 2/3
    t = complementary_peak(loop_model(unity_feedback(["2/(s+1)"]), "e", GRID, {}))
    assert t.frequency == 0.0 and t.value == pytest.approx(2 / 3, rel=1e-15)


def test_compensator_sensitivity_peak_in_a_band():
    # K = 5 (s + 1)/(s + 10) with G = 1/(s (s + 2)): L = K G, KS = K/(1 + L)
    kn, kd, gd = np.array([5.0, 5.0]), np.array([1.0, 10.0]), np.array([1.0, 2.0, 0.0])
    num, den = kn, np.polymul(kd, gd)
    model = loop_model(unity_feedback(["5*(s+1)/(s+10)", "1/(s*(s+2))"]), "e", GRID, {})

    def k_eval(w):
        s = 1j * np.asarray(w, dtype=float)
        k = np.polyval(kn, s) / np.polyval(kd, s)
        dk = (
            1j
            * (np.polyval(np.polyder(kn), s) * np.polyval(kd, s) - np.polyval(kn, s) * np.polyval(np.polyder(kd), s))
            / np.polyval(kd, s) ** 2
        )
        return k, dk

    def ks_np(w):
        s = 1j * w
        return np.abs((np.polyval(kn, s) / np.polyval(kd, s)) / (1 + np.polyval(num, s) / np.polyval(den, s)))

    def ks_mp(x):
        s = mpmath.mpc(0, x)
        k = mp_poly([5, 5], s) / mp_poly([1, 10], s)
        return abs(k / (1 + _mp_loop(num, den, x)))

    for band in (Band(0.1, 100.0), Band(0.1, 1.0)):
        p = compensator_peak(model, k_eval, band)
        w = np.geomspace(band.low, band.high, 200_001)
        v = ks_np(w)
        i = int(np.argmax(v))
        ref = float(v[i]) if i in (0, w.size - 1) else float(golden_max(ks_mp, w[i - 1], w[i + 1]))
        assert p.value == pytest.approx(ref, rel=1e-10)
        assert band.low <= p.frequency <= band.high


def test_delay_loops_are_searched_within_the_grid_and_say_so():
    model = loop_model(unity_feedback(["2/(s*(s+1))*exp(-0.1*s)"]), "e", np.geomspace(1e-2, 1e2, 50), {})
    p = sensitivity_peak(model)
    w = np.geomspace(1e-2, 1e2, 400_001)
    ref = np.max(np.abs(1 / (1 + 2 * np.exp(-0.1j * w) / (1j * w * (1j * w + 1)))))
    assert p.value == pytest.approx(ref, rel=1e-9) and p.value >= ref
    assert any("searched within" in n for n in p.notes)


def test_tabulated_loops_are_refined_on_a_fit():
    w = np.geomspace(0.01, 100, 400)
    gh = 10 / (1j * w * (1j * w + 1) * (1j * w + 5))
    p = sensitivity_peak(tabulated_loop(w, gh))
    exact = sensitivity_peak(loop_model(unity_feedback(["10/(s*(s+1)*(s+5))"]), "e", GRID, {}))
    assert p.method.startswith("fitted (residual")
    assert p.value == pytest.approx(exact.value, rel=1e-6)


def test_bad_bands_and_curves():
    model = loop_model(unity_feedback(["1/(s+1)"]), "e", GRID, {})
    with pytest.raises(EngineError, match="band"):
        sensitivity_peak(model, Band(2.0, 1.0))
    w, s, t = magnitude_curves(model, np.array([1.0, 2.0]))
    assert s == pytest.approx(np.abs((1 + 1j * w) / (2 + 1j * w)), rel=1e-14)
    assert t == pytest.approx(np.abs(1 / (2 + 1j * w)), rel=1e-14)


@pytest.mark.parametrize("text, at", [("1/s^2", 1.0), ("4/(s^2*(s^2/100 + 1))", None), ("2/(s*(s+1))", None)])
def test_a_closed_loop_pole_on_the_axis_makes_the_peaks_unbounded(text, at):
    """1/s^2 closes to 1/(s^2 + 1): |S| and |T| are infinite at 1 rad/s; the search
    refined towards the pole reported 3.2e14 (290 dB).  Shown as inf with a note;
    a loop whose closed loop is stable keeps its finite peak.  Independent check:
    the closed loop's characteristic polynomial (numpy.roots)."""
    loop = loop_model(unity_feedback([text]), "e", np.geomspace(1e-2, 1e2, 50), {})
    num = {"1/s^2": [1.0], "4/(s^2*(s^2/100 + 1))": [4.0], "2/(s*(s+1))": [2.0]}[text]
    den = {"1/s^2": [1.0, 0, 0], "4/(s^2*(s^2/100 + 1))": [0.01, 0, 1.0, 0, 0], "2/(s*(s+1))": [1.0, 1.0, 0]}[text]
    char = np.polyadd(den, num)
    on_axis = np.abs(np.roots(char).real) < 1e-9
    for peak in (sensitivity_peak(loop), complementary_peak(loop)):
        if on_axis.any():
            axis = np.abs(np.roots(char)[on_axis].imag)
            assert peak.value == math.inf and np.min(np.abs(axis - peak.frequency)) < 1e-6
            assert any(n.startswith("unbounded: 1 + GH is 0 to rounding") for n in peak.notes)
        else:
            assert math.isfinite(peak.value) and not any(n.startswith("unbounded") for n in peak.notes)
    if at is not None:
        assert sensitivity_peak(loop).frequency == pytest.approx(at, rel=1e-9)


@pytest.mark.parametrize("case", ["order-40 break", "delay", "few roots"])
def test_margins_and_peaks_together_are_each_alone(case):
    """`margins_and_peaks` refines the peaks' maxima in the margins' steps: the margins and the peaks are
    `margins` and `refined_peaks` alone, to the bit (a loop at a break of an order-40 3-loop plant and a
    loop with a delay: the detection grid's path; a loop of few roots: the grid-free path)."""
    from engine.margins.disk import disk_transform
    from engine.margins.peaks import margins_and_peaks
    from engine.margins.search import margins
    from engine.multiloop.loops import break_loop
    from engine.multiloop.plant import checked_plant
    from tests.engine.multiloop_references import random_plant

    if case == "order-40 break":
        plant = checked_plant(*random_plant(np.random.default_rng(4001), 40, 3), "plant")
        network = unity_feedback(["1"], state_space=break_loop(plant, plant.names[1]))
    else:
        network = unity_feedback(["5*(s+1)/(s*(s^2+0.05*s+4))"], delay=0.2 if case == "delay" else 0.0)
    transforms = [disk_transform(0.0), sensitivity, complementary]
    for attenuation in (None, 0.0):
        model = loop_model(network, "e", GRID, {})
        found, peaks = margins_and_peaks(model, transforms, attenuation)
        alone = loop_model(network, "e", GRID, {})
        assert repr(found) == repr(margins(alone, attenuation_above=attenuation))
        assert repr(peaks) == repr(refined_peaks(alone, transforms))


@pytest.mark.parametrize(("case", "failing"), [("few roots", "_without_grid"), ("delay", "_peaks_of")])
def test_a_failed_peak_search_costs_no_second_margin_search(monkeypatch, case, failing):
    """When the peaks' search fails, the margins are searched once and the failure is said without
    searching the peaks again (before: `margins_with_peaks` searched the margins a second time and
    `closed_loop_peaks` the peaks)."""
    import engine.margins.peaks as peaks_module
    import engine.margins.search as search_module
    from engine.analysis import analyze, margins_with_peaks
    from engine.margins.search import margins

    def network():  # each its own design (a design's loop keeps its margins)
        return unity_feedback(["5*(s+1)/(s*(s^2+0.05*s+4))"], delay=0.2 if case == "delay" else 0.0)

    expected = margins(loop_model(network(), "e", GRID, {}), attenuation_above=0.0)
    searched, tried = [], []
    search = search_module._searched
    monkeypatch.setattr(search_module, "_searched", lambda *a, **k: searched.append(1) or search(*a, **k))

    def failing_search(*args, **kwargs):
        tried.append(1)
        raise EngineError("the peaks' search failed here")

    monkeypatch.setattr(peaks_module, failing, failing_search)
    found, peaks = margins_with_peaks(loop_model(network(), "e", GRID, {}), 0.0, attenuation_above=0.0)
    assert (len(searched), len(tried)) == (1, 1)
    assert repr(found) == repr(expected) and isinstance(peaks, EngineError)
    analysis = analyze(network(), "e", GRID, {})
    assert (len(searched), len(tried)) == (2, 2)
    assert (
        analysis.disk_margin is None
        and "no disk margin or sensitivity peaks: the peaks' search failed here" in analysis.notes
    )

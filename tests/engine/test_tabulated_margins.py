"""Margins of tabulated loops: refined on a rational fit of the table, with
the fit's residual stated; report 000's grid rule stays a named method.
References: python-control's stability_margins on the rational loops the
tables are sampled from (low order, where it is right), and a dense
sampling of |1 + GH| for the stability margin."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from engine.margins.search import margins
from tests.engine.loopfactory import tabulated_loop

LOOPS = {
    "type 1 lag": ([10.0], [1.0, 6.0, 5.0, 0.0]),  # 10/(s(s+1)(s+5))
    "light resonance": ([0.3], np.polymul([1.0, 0.04, 1.0], [1.0, 1.0]).tolist()),  # zeta = 0.02 at 1 rad/s
    "non-minimum phase": ([-2.0, 4.0], [1.0, 3.0, 2.0, 0.0]),  # 2(2 - s)/(s(s+1)(s+2))
}


def _table(num, den, points: int, lo: float = 1e-2, hi: float = 1e2):
    w = np.geomspace(lo, hi, points)
    return w, np.polyval(num, 1j * w) / np.polyval(den, 1j * w)


def _reference(num, den):
    gm, pm, sm, wg, wp, ws = ct.stability_margins(ct.tf(num, den), returnall=True)
    return np.sort(wg), np.sort(wp), np.asarray(pm)[np.argsort(wp)]


def _dense_stability_minimum(num, den, lo=1e-2, hi=1e2):
    w = np.geomspace(lo, hi, 1_000_000)
    d = np.abs(1 + np.polyval(num, 1j * w) / np.polyval(den, 1j * w))
    i = np.flatnonzero((d[1:-1] < d[:-2]) & (d[1:-1] < d[2:])) + 1
    return w[i], d[i]


@pytest.mark.parametrize("points", [100, 400, 1000])
@pytest.mark.parametrize("name", list(LOOPS))
def test_fitted_margins_match_the_rational_loop_to_1e_4(name, points):
    num, den = LOOPS[name]
    w, gh = _table(num, den, points)
    found = margins(tabulated_loop(w, gh))
    assert found.method == "fitted" and found.residual < 1e-6
    wg, wp, pm = _reference(num, den)
    inside = (wg > w[0]) & (wg < w[-1])
    np.testing.assert_allclose([m.frequency for m in found.gain if m.frequency > 0], wg[inside], rtol=1e-4)
    np.testing.assert_allclose([m.frequency for m in found.phase], wp, rtol=1e-4)
    np.testing.assert_allclose([m.phase_deg for m in found.phase], pm, rtol=1e-4)
    ws, ds = _dense_stability_minimum(num, den)
    np.testing.assert_allclose([m.value for m in found.stability], ds, rtol=1e-4)
    np.testing.assert_allclose([m.frequency for m in found.stability], ws, rtol=1e-4)


def test_the_grid_rule_is_optimistic_and_the_fit_is_not():
    """On a zeta = 0.02 resonance sampled at 400 points the grid rule
    misses the true minimum of |1 + GH| (it can only land on a grid point);
    the fitted minimum agrees with the dense reference."""
    num, den = LOOPS["light resonance"]
    w, gh = _table(num, den, 400)
    grid = margins(tabulated_loop(w, gh), method="grid")
    fitted = margins(tabulated_loop(w, gh))
    _, ds = _dense_stability_minimum(num, den)
    assert min(m.value for m in grid.stability) > min(ds) * (1 + 1e-4)
    assert min(m.value for m in fitted.stability) == pytest.approx(min(ds), rel=1e-6)
    assert grid.method == "grid" and "not refined" in grid.notes[0]


def test_the_stated_residual_bounds_the_error_on_a_noisy_table():
    """Relative noise of 1e-3 on the table: the fit says so (residual of that
    size), and the margins stay within the stated residual of the truth."""
    num, den = LOOPS["type 1 lag"]
    w, gh = _table(num, den, 400)
    rng = np.random.default_rng(7)
    noisy = gh * (1 + 1e-3 * (rng.standard_normal(w.size) + 1j * rng.standard_normal(w.size)) / np.sqrt(2))
    found = margins(tabulated_loop(w, noisy))
    assert found.method == "fitted" and 5e-4 < found.residual < 2e-2
    wg, wp, pm = _reference(num, den)
    assert abs(found.phase[0].frequency / wp[0] - 1) <= found.residual
    assert abs(np.radians(found.phase[0].phase_deg - pm[0])) <= np.arcsin(found.residual)
    gain = [m for m in found.gain if m.frequency > 0][0]
    assert abs(gain.frequency / wg[0] - 1) <= found.residual


@pytest.mark.parametrize(("m", "points"), [(0.6, 11), (0.3, 11), (0.9, 15), (0.6, 21), (0.45, 13)])
def test_a_table_crossing_the_negative_real_axis_between_its_points_lists_both_gain_margins(m, points):
    """python-control's frd gain-margin case (margin_test.test_frd_indexing): |GH| = m, phase
    -180 (2 omega - 1) deg on 0.99..2.01 rad/s crosses -180 deg at 1 and 2 rad/s (its first
    points -176.4 and -213.1 deg); none was listed (the first point within the fit's
    uncertainty of -180).  Against the closed form (1/m at 1 and 2 rad/s) and python-control."""
    w = np.linspace(0.99, 2.01, points)
    gh = m * np.exp(1j * np.radians(-180 * (2 * w - 1)))
    found = margins(tabulated_loop(w, gh)).gain
    gm, _, _, wg, _, _ = ct.stability_margins(ct.frd(gh, w), returnall=True)
    np.testing.assert_allclose([g.frequency for g in found], [1.0, 2.0], atol=0.01)
    np.testing.assert_allclose([g.frequency for g in found], np.sort(wg), atol=0.01)
    np.testing.assert_allclose([10 ** (g.gain_db / 20) for g in found], [1 / m, 1 / m], rtol=0.01)

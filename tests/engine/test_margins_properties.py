"""Margins that must not depend on the grid; the grid rule for tables; w-plane loops."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback
from engine.loop.responses import loop_model
from engine.margins.search import Band, margins
from engine.model.bilinear import real_frequency, w_frequency, z_to_w
from engine.model.blocks import ExpressionTransfer, FrequencyTable, TabulatedTransfer
from engine.model.network import Block, Junction, block_diagram
from engine.numerics.polynomials import Rational
from tests.engine.loopfactory import tabulated_loop

# a rigid-body loop with a bending mode at zeta = 0.001 (gain-stabilized peak)
LIGHT_MODE = "40*(s+2)/(s*(s+10)*(s+30)) * 1/(s**2/25**2 + 2*0.001*s/25 + 1)"


def _all(m):
    return [(x.kind, x.frequency, x.value) for x in m.all()]


def test_margins_identical_on_100_and_10000_point_grids():
    net = unity_feedback([LIGHT_MODE])
    coarse = margins(loop_model(net, "e", np.geomspace(0.1, 100, 100), {}), attenuation_above=1.0)
    fine = margins(loop_model(net, "e", np.geomspace(0.1, 100, 10_000), {}), attenuation_above=1.0)
    a, b = _all(coarse), _all(fine)
    assert [k for k, _, _ in a] == [k for k, _, _ in b]
    np.testing.assert_allclose([f for _, f, _ in a], [f for _, f, _ in b], rtol=1e-9)
    np.testing.assert_allclose([v for _, _, v in a], [v for _, _, v in b], rtol=1e-9)
    # the mode's peak is found as an attenuation margin at the mode
    peak = max(coarse.attenuation, key=lambda m: m.value)
    assert peak.frequency == pytest.approx(25.0, rel=2e-3)


def test_light_mode_against_python_control():
    net = unity_feedback([LIGHT_MODE])
    m = margins(loop_model(net, "e", np.geomspace(0.1, 100, 100), {}))
    r = ExpressionTransfer(LIGHT_MODE).rational({})
    gm, pm, sm, wg, wp, ws = ct.stability_margins(ct.tf(r.num, r.den), returnall=True)
    np.testing.assert_allclose([g.frequency for g in m.gain], np.sort(wg), rtol=1e-6)
    np.testing.assert_allclose([p.phase_deg for p in m.phase], pm, rtol=1e-6)
    np.testing.assert_allclose([s.frequency for s in m.stability], np.sort(ws), rtol=1e-6)


def test_tabulated_loop_uses_the_grid_rule_when_asked():
    """A table sampled from a rational loop: the grid rule (report 000's, a
    named method) lands on the grid point nearest each refined crossing, and
    says so."""
    expr = "16000*(s+1)*(s+5)/(s*(s+8)*(s+20)*(s+0.1)*(s+50))"
    w = np.geomspace(0.5, 200, 400)
    gh = ExpressionTransfer(expr).evaluate(1j * w, {}).value
    grid = margins(tabulated_loop(w, gh), method="grid")
    exact = margins(loop_model(unity_feedback([expr]), "e", w, {}))
    assert grid.method == "grid" and exact.method == "refined"
    for g, e in [
        (grid.gain[0], exact.gain[0]),
        (grid.phase[0], exact.phase[0]),
        (grid.stability[0], exact.stability[0]),
    ]:
        i = np.argmin(np.abs(w - e.frequency))
        assert g.frequency in (w[i], w[max(i - 1, 0)], w[min(i + 1, w.size - 1)])
        assert g.value == pytest.approx(e.value, rel=2e-2)


def test_tabulated_block_in_a_diagram_is_refined_on_a_fit():
    w = np.geomspace(0.1, 100, 200)
    table = FrequencyTable.from_polar(w, 10 / (w * np.sqrt(1 + w**2)), -90 - np.degrees(np.arctan(w)))
    net = block_diagram(
        [Block("P", "e", "y", TabulatedTransfer(table))], [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))], ["r"]
    )
    a = analyze(net, "e", w, {})
    assert a.margins.method == "fitted" and a.margins.label.startswith("fitted (residual")
    assert a.verdict == "unknown"
    # 10/(s(s+1)): |GH| = 1 where w^4 + w^2 = 100, w = 3.0842
    assert a.margins.phase[0].frequency == pytest.approx(3.0842, rel=2e-2)


def test_bands_filter_gain_and_phase_margins():
    net = unity_feedback(["16000*(s+1)*(s+5)/(s*(s+8)*(s+20)*(s+0.1)*(s+50))"])
    model = loop_model(net, "e", np.geomspace(0.1, 100, 50), {})
    assert margins(model, gain_band=Band(0, 10)).gain == ()
    assert len(margins(model, gain_band=Band(10, 100)).gain) == 1
    assert margins(model, phase_band=Band(20, 100)).phase == ()


def test_w_plane_example_1_of_report_003():
    """003 Example 1: the lag (1 + 50w)/(1 + 195w) gives PM >= 50 deg, GM >= 12 dB, stable."""
    plant = "0.77*(1-w)*(1-0.136*w)*(1+0.8925*w)/(w*(1+w)*(1+2.165*w))"
    a = analyze(unity_feedback([plant, "(1+50*w)/(1+195*w)"], "w"), "e", np.geomspace(1e-3, 10, 50), {})
    assert min(p.phase_deg for p in a.margins.phase) >= 50.0
    assert min(g.gain_db for g in a.margins.gain) >= 12.0
    assert a.verdict == "stable"


def test_z_to_w_preserves_the_response_on_the_unit_circle():
    h = Rational(np.array([0.2, 0.1]), np.array([1.0, -1.5, 0.7]))
    T = 0.05
    omega = np.array([0.5, 3.0, 20.0, 60.0])
    z = np.exp(1j * omega * T)
    for scaled in (False, True):
        hw = z_to_w(h, T if scaled else None)
        nu = w_frequency(omega, T, scaled)
        np.testing.assert_allclose(hw(1j * nu), h(z), rtol=1e-12)
        np.testing.assert_allclose(real_frequency(nu, T, scaled), omega, rtol=1e-12)


def test_delay_margin_puts_the_crossover_on_minus_one():
    """Adding a delay equal to the delay margin must leave a phase margin of 0 deg
    at the same crossover (an independent check of DM = PM / omega_c)."""
    from engine.model.blocks import DelayTransfer

    expr = "16000*(s+1)*(s+5)/(s*(s+8)*(s+20)*(s+0.1)*(s+50))"
    before = analyze(unity_feedback([expr]), "e", GRID, {}).margins
    assert before.delay_margin == pytest.approx(np.radians(52.1337) / 12.0571, rel=1e-4)
    net = block_diagram(
        [Block("L", "e", "y", ExpressionTransfer(expr)), Block("D", "y", "yd", DelayTransfer(before.delay_margin))],
        [Junction("sum", "e", ((1.0, "r"), (-1.0, "yd")))],
        ["r"],
    )
    after = margins(loop_model(net, "e", np.geomspace(0.1, 100, 400), {}))
    (pm,) = [p for p in after.phase]
    assert pm.frequency == pytest.approx(before.crossover_frequency, rel=1e-12)
    assert pm.phase_deg == pytest.approx(0.0, abs=1e-9)
    assert after.notes  # searched within the grid: it says so


def test_modal_peaks_with_their_phase():
    from engine.analysis import modal_peaks

    model = loop_model(unity_feedback([LIGHT_MODE]), "e", np.geomspace(0.1, 100, 100), {})
    (peak,) = modal_peaks(model, [Band(20.0, 30.0)])
    gh = ExpressionTransfer(LIGHT_MODE).evaluate(np.array([1j * peak.frequency]), {}).value[0]
    assert peak.magnitude_db == pytest.approx(20 * np.log10(abs(gh)), rel=1e-12)
    assert peak.phase_deg == pytest.approx(np.degrees(np.angle(gh)), rel=1e-12)
    # |GH| is stationary there: d|GH|/dw = 0 (checked by central differences)
    h = 1e-6 * peak.frequency
    up, down = (
        abs(ExpressionTransfer(LIGHT_MODE).evaluate(np.array([1j * (peak.frequency + d)]), {}).value[0])
        for d in (h, -h)
    )
    assert abs(up - down) / (2 * h) < 1e-6 * abs(gh) / peak.frequency * 1e3


GRID = np.geomspace(1e-2, 1e2, 50)


@pytest.mark.parametrize("name", ["resonance above 1", "phase dipole past -180"])
def test_two_crossings_hidden_in_one_grid_interval_are_both_found(name):
    """On a deliberately coarse grid one interval holds both gain crossovers
    around a resonance poking above |GH| = 1 (ends below 1), or both phase
    crossovers of a pole-zero dipole that swings the phase past -180 deg
    (ends short of it).  The extremum inside is refined first and splits the
    interval; both crossings must match python-control's."""
    from engine.margins.detection_grid import Detection
    from engine.margins.search import _refined
    from tests.engine.loopfactory import loop_network

    s = ct.tf("s")
    system = {
        "resonance above 1": 0.1 / (s**2 + 0.02 * s + 1),
        "phase dipole past -180": 30 / (s * (s + 1)) * (s**2 + 1.05 * s + 110.25) / (s**2 + s + 100) * (100 / 110.25),
    }[name]
    grid = np.array([0.1, 0.5, 0.8, 1.3, 2.0, 5.0, 8.5, 12.5, 30.0, 100.0])
    loop = loop_model(loop_network(system.num[0][0], system.den[0][0]), "e", grid, {})
    gh, dgh = loop.evaluate(grid)
    kind, hiding = ("P", 2) if name == "resonance above 1" else ("G", 6)
    level = np.abs(gh) - 1 if kind == "P" else gh.imag
    assert np.sign(level[hiding]) == np.sign(level[hiding + 1])  # nothing to see at the interval's ends
    found = [m.frequency for m in _refined(loop, Detection(grid, gh, dgh))[kind]]
    _, _, _, wg, wp, _ = ct.stability_margins(system, returnall=True)
    expected = np.sort(wp if kind == "P" else wg)
    assert len(expected) == 2 and grid[hiding] < expected[0] < expected[1] < grid[hiding + 1]
    np.testing.assert_allclose(found, expected, rtol=1e-9)

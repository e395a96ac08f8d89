"""Step measures to the digits printed: a continuous loop's refined on the exact response against
the response written from its residues (scipy.signal.residue, roots by Brent's method on a dense
grid of its own); a sampled loop's read on its samples (python-control's discrete step)."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.signal import residue

from engine.analysis import unity_feedback
from engine.closed_loop.step_response import StepSetup, realized, step_response
from engine.model.blocks import ExpressionTransfer

LOOPS = [
    "(1+1*s)/(1+0.1*s)/(s**2*(s+10))",  # `loopcraft new --plant "1/(s^2*(s+10))" --compensator lead`, K = 1
    "4*(1+0.5*s)/(1+0.05*s)/(s**2*(s+10))",
    "25/(s*(s+3))",
    "3*(s+2)/(s*(s+1)*(s**2+0.4*s+9))",
]


class _Residues:
    """y(t) = sum r_i exp(p_i t) of the closed loop's step response T(s)/s, and y'(t)."""

    def __init__(self, expression: str):
        loop = ExpressionTransfer(expression).rational({})
        num, den = np.asarray(loop.num, float), np.polyadd(loop.den, loop.num)
        self.r, self.p, _ = residue(num, np.polymul(den, [1.0, 0.0]))
        self.final = num[-1] / den[-1]

    def y(self, t):
        return np.real(np.exp(np.multiply.outer(t, self.p)) @ self.r)

    def dy(self, t):
        return np.real(np.exp(np.multiply.outer(t, self.p)) @ (self.r * self.p))


def _roots(f, t):
    values = f(t)
    where = np.flatnonzero(np.sign(values[:-1]) * np.sign(values[1:]) < 0)
    return [brentq(f, t[i], t[i + 1], xtol=1e-14) for i in where]


@pytest.mark.parametrize("expression", LOOPS)
def test_continuous_step_measures_are_those_of_the_exact_response(expression):
    ss = realized(unity_feedback([expression]), {})
    found = step_response(ss, StepSetup())
    m = found.measures
    exact = _Residues(expression)
    t = np.linspace(0.0, found.t[-1], 200_001)
    r = lambda s: exact.y(s) / exact.final  # noqa: E731
    t10, t50, t90 = (_roots(lambda s, lv=level: r(s) - lv, t)[0] for level in (0.1, 0.5, 0.9))
    peaks = _roots(exact.dy, t)
    peak_time = max(peaks, key=lambda s: exact.y(s))
    settle = _roots(lambda s: np.abs(r(s) - 1.0) - 0.05, t)[-1]
    assert m.final == pytest.approx(exact.final, rel=1e-12)
    assert m.rise_time == pytest.approx(t90 - t10, rel=1e-9)
    assert m.delay_time == pytest.approx(t50, rel=1e-9)
    assert m.peak_time == pytest.approx(peak_time, rel=1e-9)
    assert m.overshoot_percent == pytest.approx(100 * (r(peak_time) - 1.0), rel=1e-9)
    assert m.settling_time == pytest.approx(settle, rel=1e-9)


def test_a_lead_s_measures_differ_from_grid_interpolation_in_the_printed_digits():
    """The case of the issue: linear interpolation on 400 samples was wrong in the third digit."""
    expression = LOOPS[0]
    found = step_response(realized(unity_feedback([expression]), {}), StepSetup())
    exact = _Residues(expression)
    peak_time = max(_roots(exact.dy, np.linspace(0.0, found.t[-1], 200_001)), key=lambda s: exact.y(s))
    assert f"{found.measures.peak_time:.6g}" == f"{peak_time:.6g}"
    assert f"{found.t[int(np.argmax(found.y))]:.6g}" != f"{peak_time:.6g}"


def test_sampled_step_measures_are_read_on_the_samples():
    """Kuo's plant in z with a gain: every measure a sample time (no interpolation), the settling
    time the first sample after which all stay in the band, the peak the largest sample."""
    from engine.model.network import sampled_network

    T = 0.1
    plant = "0.0484*(z+0.9672)/((z-1)*(z-0.9048))"
    network = sampled_network(unity_feedback([f"0.5*{plant}"], variable="z"), T)
    found = step_response(realized(network, {}), StepSetup())
    m = found.measures
    z = ct.tf([1, 0], [1], T)
    L = 0.5 * 0.0484 * (z + 0.9672) / ((z - 1) * (z - 0.9048))
    samples = np.arange(np.unique(found.t).size) * T
    _, y = ct.step_response(ct.feedback(L, 1), T=samples)
    final = 1.0
    r = y / final
    outside = np.flatnonzero(np.abs(r - 1.0) > 0.05)
    assert m.settling_time == pytest.approx(samples[outside[-1] + 1], abs=1e-12)
    assert m.rise_time == pytest.approx(samples[np.argmax(r >= 0.9)] - samples[np.argmax(r >= 0.1)], abs=1e-12)
    assert m.peak_time == pytest.approx(samples[np.argmax(r)], abs=1e-12)
    assert m.overshoot_percent == pytest.approx(100 * (r.max() - 1.0), rel=1e-9)
    for value in (m.settling_time, m.rise_time, m.peak_time, m.delay_time):
        assert value / T == pytest.approx(round(value / T), abs=1e-9)

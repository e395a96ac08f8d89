"""A loop with a tabulated plant is stepped with its table's rational fit, each measure with an error
estimate (the fit of every other table point): checked against the step response of the rational plant
the table samples, written from its residues (scipy.signal.residue, crossings by Brent's method on a
dense grid of its own), so every measure printed to the digits its estimate supports is right."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.signal import residue

from engine.analysis import unity_feedback
from engine.closed_loop.delayed_step import digits_supported
from engine.closed_loop.step_response import network_step
from engine.model.blocks import ExpressionTransfer, FrequencyTable

# (compensator, plant): the plant tabulated at 300 points over 0.01..100 rad/s
LOOPS = [
    ("1", "3*(s+2)/(s*(s+1)*(s**2+0.4*s+9))"),
    ("(1+1*s)/(1+0.1*s)", "1/(s**2*(s+10))"),
    ("2", "1/(s*(s+1)*(0.2*s+1))"),
]


def _exact(compensator: str, plant: str) -> dict[str, float]:
    """The measures of the rational loop's step response, from its residues."""
    loop = ExpressionTransfer(f"({compensator})*({plant})").rational({})
    num, den = np.asarray(loop.num, float), np.polyadd(loop.den, loop.num)
    r, p, _ = residue(num, np.polymul(den, [1.0, 0.0]))
    final = num[-1] / den[-1]
    y = lambda t: np.real(np.exp(np.multiply.outer(t, p)) @ r) / final  # noqa: E731
    dy = lambda t: np.real(np.exp(np.multiply.outer(t, p)) @ (r * p))  # noqa: E731
    t = np.linspace(0.0, 8.0 / np.min(np.abs(p[p.real < 0].real)), 200_001)

    def roots(f):
        v = f(t)
        return [brentq(f, t[i], t[i + 1], xtol=1e-14) for i in np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)]

    t10, t50, t90 = (roots(lambda s, lv=level: y(s) - lv)[0] for level in (0.1, 0.5, 0.9))
    peak_time = max(roots(dy), key=lambda s: y(s))
    return {
        "final": final,
        "rise_time": t90 - t10,
        "delay_time": t50,
        "peak_time": peak_time,
        "overshoot_percent": (y(peak_time) - 1.0) * 100.0,
        "settling_time": roots(lambda s: np.abs(y(s) - 1.0) - 0.05)[-1],
    }


@pytest.mark.parametrize(
    ("compensator", "plant"),  # (two of them under the slow marker: each fits two tables, about 2 s)
    [LOOPS[0], *(pytest.param(*loop, marks=pytest.mark.slow) for loop in LOOPS[1:])],
)
def test_a_tabulated_loop_s_step_measures_are_right_to_the_digits_printed(compensator, plant):
    omega = np.logspace(-2, 2, 300)
    gh = ExpressionTransfer(plant).rational({})
    response = np.polyval(gh.num, 1j * omega) / np.polyval(gh.den, 1j * omega)
    table = FrequencyTable.from_cartesian(omega, response.real, response.imag)
    found = network_step(unity_feedback([compensator], table=table), {})
    assert found is not None and found.measures is not None  # (main: None, a table had no step response)
    assert "rational fit" in found.how and "every other table point" in found.how
    exact = _exact(compensator, plant)
    for name, value in exact.items():
        got, error = getattr(found.measures, name), found.errors[name]
        assert abs(got - value) <= max(error, 1e-9 * abs(value)), (name, got, value, error)
        digits = digits_supported(got, error)
        assert digits >= 3, (name, digits, error)  # a table this fine supports three digits at least
        assert float(f"{got:.{digits}g}") == pytest.approx(
            value, abs=10 ** (np.floor(np.log10(abs(value))) - digits + 1)
        )


def test_a_zero_and_a_pole_by_the_origin_are_put_there_and_cancel():
    """(s + 1e-6) / (s (s + 1)) tabulated from 0.01 rad/s: the table cannot tell its zero and pole from 0
    (1e-4 relative at its lowest point), so the model is 1/(s + 1), no hidden mode at 0 left in the loop,
    with the residual that costs (about 1e-4) restated."""
    from engine.loop.table_model import table_model

    omega = np.logspace(-2, 2, 200)
    s = 1j * omega
    model = table_model(omega, (s + 1e-6) / (s * (s + 1)), "test")
    assert model.zeros.size == 0 and model.poles == pytest.approx([-1.0], rel=1e-6)
    assert 5e-5 < model.residual < 2e-4


def test_a_tabulated_plant_behind_a_delay_is_simulated_with_its_fit():
    """exp(-s) / (s + 1) with the plant 1/(s + 1) a table (300 points, 0.01-100 rad/s), unity gain: by the
    method of steps the peak is at 2 + 1/e s, overshoot 2 exp(-1/e) - 1, the rise time ln(0.95/0.55) s
    (as tests/test_report_content.py's delay loop); each measure within its stated error (main: no step
    response, a loop with a table and a delay)."""
    import math

    omega = np.logspace(-2, 2, 300)
    response = 1 / (1j * omega + 1)
    table = FrequencyTable.from_cartesian(omega, response.real, response.imag)
    found = network_step(unity_feedback(["1"], delay=1.0, table=table), {})
    assert found is not None and found.measures is not None
    assert "simulated with the delay on a grid of" in found.how and "rational fit" in found.how
    exact = {
        "rise_time": math.log(0.95 / 0.55),
        "overshoot_percent": (2 * math.exp(-math.exp(-1)) - 1) * 100,
        "peak_time": 2 + math.exp(-1),
        "final": 0.5,
    }
    for name, value in exact.items():
        got, error = getattr(found.measures, name), found.errors[name]
        assert error < 1e-4 and abs(got - value) <= 3 * error, (name, got, value, error)

"""A continuous loop with a time delay has a step response and step measures (issue 52: "a tabulated
plant's (simulated on a grid) is printed to the digits its grid supports, with how it was obtained"; the
same for a delay loop): simulated on two grids whose difference is each measure's stated error.

The references are independent: K exp(-T s)/(s + a) under unity feedback, y' = -a y + K (1 - y(t - T)),
solved by the method of steps (y = 0 before T; on [T, 2T] the input is 1; on [2T, 3T] it is 1 - y(t - T),
the first piece), and its rightmost characteristic root s + a + K exp(-T s) = 0 by Lambert's W."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import lambertw

from engine.analysis import unity_feedback
from engine.closed_loop.delayed_step import common_step, delayed_step, digits_supported
from engine.closed_loop.step_response import StepSetup, network_step, realized, step_response
from engine.errors import EngineError
from engine.model.blocks import DelayTransfer, ExpressionTransfer
from engine.model.network import Block, Junction, block_diagram


def method_of_steps(t: np.ndarray, K: float, a: float, T: float) -> np.ndarray:
    """y on [0, 3T] of y' = -a y + K (1 - y(t - T)), y = 0 for t <= T."""
    y = np.full_like(t, np.nan)
    y[t < T] = 0.0
    first = (t >= T) & (t < 2 * T)
    y[first] = K / a * (1 - np.exp(-a * (t[first] - T)))
    second = (t >= 2 * T) & (t <= 3 * T)
    u = t[second] - 2 * T
    y2 = K / a * (1 - math.exp(-a * T))  # y(2T)
    # y' + a y = (K - K^2/a) + (K^2/a) exp(-a u): a constant's response, and c exp(-a u) -> c u exp(-a u)
    y[second] = y2 * np.exp(-a * u) + (K - K * K / a) / a * (1 - np.exp(-a * u)) + K * K / a * u * np.exp(-a * u)
    return y


def test_a_first_order_loop_with_delay_matches_the_method_of_steps_to_its_stated_error():
    K, a, T = 1.0, 1.0, 1.0
    found = delayed_step(unity_feedback([f"{K}/(s+{a})*exp(-{T}*s)"]), {}, "r", "y")
    early = found.t <= 3 * T
    error = np.max(np.abs(found.y[early] - method_of_steps(found.t[early], K, a, T)))
    assert error <= 3 * found.curve_error and found.curve_error < 1e-5
    m = found.measures
    assert m is not None and m.final == pytest.approx(K / (K + a), rel=1e-12) and m.final_from == "dc_gain"
    # on [T, 2T]: y = 1 - exp(-(t - T)) crosses 10 % and 90 % of 1/2 at -ln(0.95) and -ln(0.55) after T
    rise = math.log(0.95) - math.log(0.55)
    # on [2T, 3T]: y = (1 - 1/e + u) exp(-u), y' = (1/e - u) exp(-u): the peak at u = 1/e, y = exp(-1/e)
    peak_time, peak = 2 * T + math.exp(-1), math.exp(-math.exp(-1))
    overshoot = (peak / m.final - 1) * 100
    for name, exact in (
        ("rise_time", rise),
        ("peak_time", peak_time),
        ("peak", peak),
        ("overshoot_percent", overshoot),
    ):
        value, stated = getattr(m, name), found.errors[name]
        assert abs(value - exact) <= 3 * stated + 1e-12, (name, value, exact, stated)
        assert stated < 1e-4 * max(abs(exact), 1)
    assert abs(m.delay_time - (T - math.log(0.75))) <= 3 * found.errors["delay_time"]  # y = 1/4 on [T, 2T]
    assert "simulated with the delay on a grid of" in found.how and "error about" in found.how


def test_the_rightmost_root_and_the_verdict_come_from_the_scheme_itself():
    for K, stable in ((1.0, True), (3.0, False)):
        found = delayed_step(unity_feedback([f"{K}/(s+1)*exp(-1*s)"]), {}, "r", "y")
        # s + 1 + K exp(-s) = 0: q = s + 1, q exp(q) = -K e, q = W_0(-K e)
        exact = complex(lambertw(-K * math.e, 0)) - 1
        assert found.rightmost is not None
        assert found.rightmost.real == pytest.approx(exact.real, abs=2e-3)
        assert found.rightmost.imag == pytest.approx(abs(exact.imag), abs=2e-3)
        assert (found.measures is not None) is stable


def test_an_unstable_delay_loop_shows_a_growing_response_without_crashing():
    network = unity_feedback(["3/(s+1)*exp(-1*s)"])
    response = network_step(network, {})
    assert response is not None and response.measures is None
    y = np.abs(np.array(response.y))
    assert y[-1] > 100 * y[len(y) // 4] > 0
    far = network_step(network, {}, StepSetup(horizon=5000.0))  # e^(0.21 t) leaves the float range
    assert far is not None and far.note is not None and "floating-point range" in far.note
    assert np.all(np.isfinite(far.y)) and far.t[-1] < 5000.0


def test_a_jump_echoed_by_the_delay_falls_on_a_sample_both_limits_kept():
    """0.5 (s+2)/(s+1) = 0.5 + 0.5/(s+1): its direct part makes y jump at T = 0.3 from 0 to 1/2; on
    [T, 2T] the input is 1: y = 0.5 + 0.5 (1 - exp(-(t - T)))."""
    found = delayed_step(unity_feedback(["0.5*(s+2)/(s+1)*exp(-0.3*s)"]), {}, "r", "y")
    t, y = found.t, found.y
    at = np.flatnonzero(np.isclose(t, 0.3, rtol=0, atol=1e-12))
    assert at.size == 2 and y[at[0]] == 0.0 and y[at[1]] == pytest.approx(0.5, abs=1e-12)
    inside = (t > 0.3) & (t < 0.6)
    assert np.max(np.abs(y[inside] - (0.5 + 0.5 * (1 - np.exp(-(t[inside] - 0.3)))))) < 1e-6
    assert found.measures is not None and found.measures.delay_time == pytest.approx(0.3, abs=1e-12)


def test_a_loop_without_delay_keeps_the_exact_path():
    network = unity_feedback(["4/(s*(s+2))"])
    response = network_step(network, {})
    exact = step_response(realized(network, {}), StepSetup())
    assert response == exact and response.errors is None and response.how is None


def test_two_delays_share_a_step_or_are_refused():
    assert common_step((0.5, 0.3)) == pytest.approx(0.1)
    with pytest.raises(EngineError, match="no common step"):
        common_step((1.0, math.pi / 3))
    blocks = [
        Block("C", "e", "u", ExpressionTransfer("2/(s+1)")),
        Block("d1", "u", "v", DelayTransfer(0.5)),
        Block("P", "v", "w", ExpressionTransfer("1/(s+2)")),
        Block("d2", "w", "y", DelayTransfer(0.3)),
    ]
    network = block_diagram(blocks, [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))], ["r"])
    one = unity_feedback(["2/(s+1)/(s+2)*exp(-0.8*s)"])  # the same loop, the delays in one
    a, b = network_step(network, {}), network_step(one, {})
    assert a is not None and b is not None and a.measures is not None
    assert a.measures.peak_time == pytest.approx(b.measures.peak_time, abs=3 * (a.errors["peak_time"] + 1e-9))
    assert a.measures.overshoot_percent == pytest.approx(
        b.measures.overshoot_percent, abs=3 * (a.errors["overshoot_percent"] + b.errors["overshoot_percent"])
    )


def test_digits_follow_the_error():
    assert digits_supported(2.36788, 4e-6) == 6
    assert digits_supported(2.36788, 4e-3) == 3
    assert digits_supported(38.44, 0.05) == 3
    assert digits_supported(1.0, math.inf) == 1


def test_the_settling_time_against_the_method_of_steps_integrated_finely():
    """Beyond 3T the pieces are long to write: y' = -y + r(t - 1) - y(t - 1) integrated interval by interval
    (solve_ivp, rtol 1e-12, each interval reading the previous one's dense output), and the last crossing
    of the 5 % band about 1/2 found on it."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    pieces = [lambda t: 0.0 * t]  # y on [-1, 0]
    for k in range(12):
        before = pieces[-1]
        sol = solve_ivp(
            lambda t, y, before=before, on=float(k >= 1): [-y[0] + on - before(t - 1.0)],  # r(t - 1) = 0 on [0, 1)
            (k, k + 1.0),
            [float(pieces[-1](k)) if k else 0.0],
            rtol=1e-12,
            atol=1e-14,
            dense_output=True,
        )
        pieces.append(lambda t, f=sol.sol: f(t)[0])

    def y(t: float) -> float:
        return float(pieces[min(int(t), 11) + 1](t))

    grid = np.linspace(0, 12, 12001)
    outside = [t for t in grid if abs(y(t) / 0.5 - 1) > 0.05]
    last = outside[-1]
    level = 0.5 * (1.05 if y(last) > 0.5 else 0.95)
    settling = brentq(lambda t: y(t) - level, last, last + 0.001, xtol=1e-13)
    found = delayed_step(unity_feedback(["1/(s+1)*exp(-1*s)"]), {}, "r", "y")
    assert abs(found.measures.settling_time - settling) <= 3 * found.errors["settling_time"] + 1e-9


@pytest.mark.parametrize(
    "text", ["1/(s+1)*exp(-1*s)", "0.5*(s+2)/(s+1)*exp(-0.3*s)", "(s+3)/((s+1)*(s^2+s+4))*exp(-0.05*s)"]
)
def test_the_recurrence_and_the_blocks_are_one_scheme(text):
    """Short delays are stepped as one recurrence on the state and the rings: the same numbers as block by block."""
    from engine.closed_loop.time_response import simulate_delayed
    from engine.loop.realization import realize_opened

    opened = realize_opened(unity_feedback([text]), {})
    lag = 7
    delays = [(lag, opened.delay_inputs[0], opened.delay_outputs[0])]
    h = opened.taus[0] / lag
    a = simulate_delayed(opened.ss, "r", delays, h, 300, how="blocks")
    b = simulate_delayed(opened.ss, "r", delays, h, 300, how="recurrence")
    assert np.array_equal(a.t, b.t)
    assert np.allclose(a.y, b.y, rtol=1e-10, atol=1e-12) and np.allclose(a.right, b.right, rtol=1e-10, atol=1e-12)


def test_a_delay_too_short_for_the_horizon_is_cut_with_a_note_and_no_measures():
    network = unity_feedback(["0.5/(s*(s+1))*exp(-1e-6*s)"])
    response = network_step(network, {})
    assert response is not None and response.measures is None and "no measures" in response.note
    assert len(response.t) <= 20_001

"""Closed-loop poles and time responses against python-control, and the
step measures against the second-order formulas."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.closed_loop.time_response import Segment, dc_gain, simulate, step_measures
from engine.loop.realization import Pole, poles, realize, stability, unstable_rows
from engine.model.blocks import ExpressionTransfer
from engine.model.network import Block, Junction, block_diagram
from tests.engine.loopfactory import loop_network, random_loop

COMPENSATED = "16000*(s+1)*(s+5)/(s*(s+8)*(s+20)*(s+0.1)*(s+50))"


def _pc_closed_loop(expr):
    r = ExpressionTransfer(expr).rational({})
    return ct.feedback(ct.tf(r.num, r.den), 1)


def test_closed_loop_poles_match_python_control():
    ours = np.sort_complex([p.value for p in poles(realize(unity_feedback([COMPENSATED]), {}))])
    theirs = np.sort_complex(ct.poles(_pc_closed_loop(COMPENSATED)))
    np.testing.assert_allclose(ours, theirs, rtol=1e-9)


@pytest.mark.parametrize("seed", range(0, 40, 3))
def test_closed_loop_poles_of_random_loops(seed):
    num, den = random_loop(seed)
    ours = np.sort_complex([p.value for p in poles(realize(loop_network(num, den), {}))])
    theirs = np.sort_complex(np.roots(np.polyadd(num, den)))
    np.testing.assert_allclose(ours, theirs, rtol=1e-5, atol=1e-8)


def test_stability_verdicts():
    assert stability(poles(realize(unity_feedback([COMPENSATED]), {}))) == "stable"
    assert stability(poles(realize(unity_feedback(["16000/(s*(s+8)*(s+20))"]), {}))) == "unstable"
    # an undamped closed loop: 1/s^2 with unity feedback -> s^2 + 1
    assert stability(poles(realize(unity_feedback(["1/s**2"]), {}))) == "marginally stable"


def test_the_batched_verdict_is_the_per_loop_one():
    """`unstable_rows` (a stack of loops' poles at once) gives `stability`'s 'unstable' on each row:
    a pole right of the axis by less than `AXIS` of its modulus, or at the origin beside a fast
    pole, is on the axis; by more, unstable."""
    rows = np.array(
        [
            [-1.0, 3e-13 + 2j, 3e-13 - 2j],  # on the axis (|zeta| 1.5e-13)
            [-1.0, 3e-12 + 2j, 3e-12 - 2j],  # right of it (|zeta| 1.5e-12)
            [-5.0, 2e-12, -1.0],  # at the origin beside a pole of modulus 5
            [-5.0, 1e-10, -1.0],  # a slow unstable pole
            [-5.0, -1.0, -2.0],
        ]
    )
    verdicts = [stability([Pole(complex(p), 0.0, abs(p)) for p in row]) == "unstable" for row in rows]
    assert verdicts == [False, True, False, True, False]
    assert unstable_rows(rows).tolist() == verdicts


def test_step_response_matches_python_control():
    net = unity_feedback([COMPENSATED])
    t = np.linspace(0, 3, 601)
    y = simulate(realize(net, {}), "r", t, [Segment(0.0, step=1.0)])[:, net.signal("y")]
    np.testing.assert_allclose(y, ct.step_response(_pc_closed_loop(COMPENSATED), t).outputs, atol=1e-12)


def test_wind_profile_of_steps_and_ramps_matches_python_control():
    net = unity_feedback([COMPENSATED])
    t = np.linspace(0, 4, 801)
    profile = [Segment(0.0, step=0.5), Segment(1.0, slope=2.0), Segment(2.0, slope=-2.0, step=-1.0)]
    y = simulate(realize(net, {}), "r", t, profile)[:, net.signal("y")]
    # superposition of python-control's step and ramp responses, shifted by whole
    # samples (python-control's own input interpolation cannot hold a jump)
    cl = _pc_closed_loop(COMPENSATED)
    step = ct.step_response(cl, t).outputs
    ramp = ct.forced_response(cl, t, t).outputs

    def delayed(r, t0):
        k = int(round(t0 / (t[1] - t[0])))
        return np.concatenate([np.zeros(k), r[: t.size - k]])

    expected = 0.5 * step + 2.0 * delayed(ramp, 1.0) - delayed(step, 2.0) - 2.0 * delayed(ramp, 2.0)
    np.testing.assert_allclose(y, expected, atol=1e-9)


def test_second_order_step_measures_match_the_formulas():
    zeta, wn = 0.3, 5.0
    net = block_diagram(
        [Block("G", "e", "y", ExpressionTransfer(f"{wn**2}/(s*(s+{2 * zeta * wn}))"))],
        [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))],
        ["r"],
    )
    ss = realize(net, {})
    t = np.linspace(0, 6, 60001)
    y = simulate(ss, "r", t, [Segment(0.0, step=1.0)])[:, net.signal("y")]
    m = step_measures(t, y, dc_gain(ss, "r")[net.signal("y")], band=0.05)
    wd = wn * np.sqrt(1 - zeta**2)
    assert m.overshoot_percent == pytest.approx(100 * np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2)), rel=1e-6)
    assert m.peak_time == pytest.approx(np.pi / wd, abs=1e-4)
    assert m.steady_state_error == pytest.approx(0.0, abs=1e-12)
    info = ct.step_info(
        ct.tf([wn**2], [1, 2 * zeta * wn, wn**2]), T=t, SettlingTimeThreshold=0.05, RiseTimeLimits=(0.1, 0.9)
    )
    assert m.rise_time == pytest.approx(info["RiseTime"], abs=2e-4)
    assert m.settling_time == pytest.approx(info["SettlingTime"], abs=2e-4)

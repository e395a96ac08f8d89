"""Delay loops below or above the plot grid (issue 35, section 4): the search range comes
from the loop (its corners and crossovers), not from the plot grid; where the delay's grid
bounds it with |GH| >= 1 still, the delay margin is 'not known', never 'none'."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from scipy.optimize import brentq

from engine.analysis import analyze, unity_feedback
from engine.closed_loop.poles import closed_loop_verdict
from engine.model.blocks import DelayTransfer, ExpressionTransfer
from engine.model.network import Block, Junction, block_diagram

DEFAULT_GRID = np.logspace(-3, 3, 400)


def _mpmath_margins(gain: float, corner: float, delay: float) -> tuple[float, float, float]:
    """gain/(s (1 + s/corner)) exp(-delay s): crossover, phase margin (deg), delay margin (s)."""
    mpmath.mp.dps = 40
    k, a, tau = mpmath.mpf(gain), mpmath.mpf(corner), mpmath.mpf(delay)
    wc = mpmath.sqrt(a**2 / 2 * (mpmath.sqrt(1 + 4 * k**2 / a**2) - 1))  # w^2 (1 + w^2/a^2) = k^2
    pm = mpmath.pi / 2 - mpmath.atan(wc / a) - wc * tau
    return float(wc), float(mpmath.degrees(pm)), float(pm / wc)


def test_a_crossover_below_the_plot_grid_is_found() -> None:
    """2e-4/(s (1 + s/1e-4)) exp(-3000 s): on the default grid, no phase margin and a null
    delay margin ('any delay tolerated') before."""
    a = analyze(unity_feedback(["2e-4/(s*(1+s/1e-4))"], delay=3000.0), "e", DEFAULT_GRID, {})
    wc, pm, dm = _mpmath_margins(2e-4, 1e-4, 3000.0)
    assert a.margins.crossover_frequency == pytest.approx(wc, rel=1e-10)
    assert a.margins.phase[0].phase_deg == pytest.approx(pm, rel=1e-9)
    assert a.delay_margin == pytest.approx(dm, rel=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_margins_do_not_depend_on_the_plot_grid(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for _ in range(4):
        corner, delay = 10 ** rng.uniform(-6, -4), 10 ** rng.uniform(2, 3.5)
        gain = corner * 10 ** rng.uniform(-0.5, 0.5) / 10  # crossover near the corner, far below 1e-3
        if _mpmath_margins(gain, corner, delay)[1] <= 0:
            continue
        wc, pm, dm = _mpmath_margins(gain, corner, delay)
        for grid in (DEFAULT_GRID, np.logspace(-9, 1, 300)):
            a = analyze(unity_feedback([f"{gain!r}/(s*(1+s/{corner!r}))"], delay=delay), "e", grid, {})
            assert a.delay_margin == pytest.approx(dm, rel=1e-8)
            assert a.margins.crossover_frequency == pytest.approx(wc, rel=1e-9)


def test_a_search_cut_by_the_delay_grid_still_has_the_closed_loop_s_verdict() -> None:
    """1e6/(s (1 + s/1e-4)) exp(-3000 s) crosses over at 10 rad/s, beyond the 5.2 rad/s the
    delay's grid can follow: its Ms and Mt are those of the searched range.  The closed loop is
    unstable (a root of s (1 + s/1e-4) + 1e6 exp(-3000 s) at Re s > 0, found by mpmath): the
    certified argument count says so, with the delay exact, so the delay margin is 0 (it was
    left unknown when the loop's verdict was)."""
    a = analyze(unity_feedback(["1e6/(s*(1+s/1e-4))"], delay=3000.0), "e", DEFAULT_GRID, {})
    with mpmath.workdps(20):
        f = lambda s: s * (1 + s / mpmath.mpf("1e-4")) + 1e6 * mpmath.exp(-3000 * s)  # noqa: E731
        root = mpmath.findroot(f, mpmath.mpc("0.00423", "0.01692"), tol=1e-24)
        assert root.real > 1e-3 and abs(f(root)) < 1e-12
    assert a.verdict == "unstable" and a.delay_margin == 0.0
    assert any("root(s) in the right half-plane" in n and "the delays exact" in n for n in a.notes)
    assert any("Ms and Mt are those of the searched range" in n for n in a.notes)


def _power_loop_truth(k: float, power: int, tau: float) -> tuple[float, float, float, float]:
    """K/s^power exp(-tau s), K > 0, in closed form (mpmath): crossover |K|^(1/power), phase
    margin 180 - 90 power - omega_c tau (deg), the lowest positive phase crossing
    omega tau = (2 j + 1) pi - power pi/2 and its gain margin omega^power / K."""
    mpmath.mp.dps = 40
    K, t = mpmath.mpf(k), mpmath.mpf(tau)
    wc = K ** (mpmath.mpf(1) / power)
    pm = 180 - 90 * power - mpmath.degrees(wc * t)
    j = 0
    while (2 * j + 1) * mpmath.pi - power * mpmath.pi / 2 <= 0:
        j += 1
    w1 = ((2 * j + 1) * mpmath.pi - power * mpmath.pi / 2) / t
    return float(wc), float(pm), float(w1), float(w1**power / K)


def _random_power_loop(seed: int) -> tuple[float, int, float]:
    """K/s^k exp(-tau s) crossing over at 1e-6..1e6 rad/s with omega_c tau in 1e-3..1e3
    (the delay grid follows 5000 half-turns of the phase: beyond, its note says so)."""
    rng = np.random.default_rng(seed)
    wc, power = 10 ** rng.uniform(-6, 6), int(rng.integers(1, 4))
    return float(wc**power), power, float(10 ** rng.uniform(-3, 3) / wc)


POWER_LOOPS = [(1e8, 2, 1e-5), (1e-5, 1, 1000.0), (1.55e-8, 1, 990000.0)] + [_random_power_loop(s) for s in range(8)]


@pytest.mark.parametrize(("k", "power", "tau"), POWER_LOOPS)
def test_a_loop_with_no_corners_is_searched_about_its_crossover(k: float, power: int, tau: float) -> None:
    """K/s^k with a delay has no corner: its search range came from the plot grid alone, so
    1e8/s^2 exp(-1e-5 s) (crossover 1e4 rad/s, PM -5.73 deg) had no crossing, and 1.55e-8/s
    exp(-990000 s) listed its first gain margin at 1e-3 rad/s (true: 1.587e-6)."""
    a = analyze(unity_feedback([f"{k!r}/s**{power}"], delay=tau), "e", DEFAULT_GRID, {})
    wc, pm, w1, gm = _power_loop_truth(k, power, tau)
    assert [p.frequency for p in a.margins.phase] == [pytest.approx(wc, rel=1e-9)]
    assert (a.margins.phase[0].phase_deg - pm + 180) % 360 - 180 == pytest.approx(0, abs=1e-6)
    lowest = min(a.margins.listed("G"), key=lambda m: m.frequency)
    assert lowest.frequency == pytest.approx(w1, rel=1e-9)
    assert 10 ** (-lowest.gain_db / 20) == pytest.approx(1 / gm, rel=1e-8)


def test_the_ten_lowest_gain_margins_are_found_above_the_plot_grid() -> None:
    """1/(s + 1) exp(-1e-5 s): its phase crosses -180 deg first near 1.6e5 rad/s, above the
    plot grid's 1e3 rad/s (none was listed); the 10 lowest, against brentq on its phase."""
    a = analyze(unity_feedback(["1/(s+1)"], delay=1e-5), "e", DEFAULT_GRID, {})
    first = [m.frequency for m in sorted(a.margins.listed("G"), key=lambda m: m.frequency)][:10]
    truth = [brentq(lambda w: (2 * j + 1) * np.pi - np.arctan(w) - w * 1e-5, 0.0, 1e7) for j in range(10)]
    np.testing.assert_allclose(first, truth, rtol=1e-9)


def test_fewer_than_the_ten_lowest_gain_margins_are_said_where_the_search_stopped() -> None:
    """Where a delay loop's search ends below its 10 lowest gain margins, a note names where."""
    from engine.margins.detection_grid import Detection
    from engine.margins.search import _few_delay_margins

    a = analyze(unity_feedback(["1/(s+1)"], delay=1e-5), "e", DEFAULT_GRID, {})
    assert not any("fewer than the 10 lowest" in n for n in a.notes)
    loop = type("Loop", (), {"delay": 1e-5})()
    grid = Detection(np.array([1e-3, 2e5]), np.ones(2, complex), np.ones(2, complex))
    (note,) = _few_delay_margins(loop, grid, 3)
    assert note.startswith("3 gain margin(s) found, fewer than the 10 lowest: the search stops at 200000 rad/s")
    assert _few_delay_margins(loop, grid, 10) == []


@pytest.mark.parametrize("k", [0.5, 1.0, 4.0])
@pytest.mark.parametrize("side", [0.9, 1.1])
def test_a_delayed_loop_s_closed_loop_verdict(k: float, side: float) -> None:
    """K/(s (s+1)) exp(-tau s) is stable exactly while tau is below its delay margin
    (pi/2 - atan(wc))/wc, wc from wc sqrt(1 + wc^2) = K (one crossover, closed form): the loop's
    verdict comes from the certified argument count with the delay exact (it was 'unknown', and an
    unstable loop's disk margin was reported as if it were stable)."""
    wc = math.sqrt((math.sqrt(1 + 4 * k * k) - 1) / 2)
    tau = side * (math.pi / 2 - math.atan(wc)) / wc
    a = analyze(unity_feedback([f"{k}/(s*(s+1))"], delay=tau), "e", DEFAULT_GRID, {})
    assert a.verdict == ("stable" if side < 1 else "unstable")
    assert (a.disk_margin.alpha > 0) == (side < 1)


@pytest.mark.parametrize(("gain", "verdict"), [(1.0, "stable"), (10.0, "unstable")])
def test_a_delay_named_by_a_parameter_at_0_is_a_unit_gain(gain: float, verdict: str) -> None:
    """A delay block whose parameter is 0 leaves a rational closed loop: its verdict is its poles'
    (K/(s (s+1) (s+2)): s^3 + 3 s^2 + 2 s + K, stable while K < 6 by Routh); the count had no delay
    to count with and said 'unknown'."""
    blocks = [
        Block("G", "e", "u", ExpressionTransfer(f"{gain}/(s*(s+1)*(s+2))")),
        Block("lag", "u", "y", DelayTransfer("tau")),
    ]
    network = block_diagram(blocks, [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))], ["r"])
    assert closed_loop_verdict(network, {"tau": 0.0}) == verdict

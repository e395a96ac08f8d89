"""Delay loops below or above the plot grid (issue 35, section 4): the search range comes
from the loop (its corners and crossovers), not from the plot grid; where the delay's grid
bounds it with |GH| >= 1 still, the delay margin is 'not known', never 'none'."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback

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


def test_a_search_cut_by_the_delay_grid_leaves_the_delay_margin_unknown() -> None:
    """1e6/(s (1 + s/1e-4)) exp(-3000 s) crosses over at 10 rad/s, beyond the 5.2 rad/s the
    delay's grid can follow."""
    a = analyze(unity_feedback(["1e6/(s*(1+s/1e-4))"], delay=3000.0), "e", DEFAULT_GRID, {})
    assert math.isnan(a.delay_margin)
    assert any("the delay margin is not known" in n for n in a.notes)
    assert any("Ms and Mt are those of the searched range" in n for n in a.notes)

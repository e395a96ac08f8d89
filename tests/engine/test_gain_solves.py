"""The loop-gain solves (issue 38, section 1): the gain for a crossover frequency and the
gain for a phase margin, checked on ten loops against python-control's stability
margins of the scaled loop (an independent computation: its own polynomial evaluation
and crossing search), and the reason given when no gain does."""

from __future__ import annotations

import control as ct
import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.design.gain_solves import gain_for_crossover, gain_for_phase_margin
from engine.errors import EngineError
from engine.loop.responses import loop_model

LOOPS = [  # zeros, poles, gain
    ([-0.3], [0, 0, -10, -3], 10.0),
    ([], [0, -1, -5], 1.0),
    ([-2], [0, -1, -8], 1.0),
    ([], [-1, -1, -1], 1.0),
    ([-0.5], [0, 0, -20], 10.0),
    ([], [0, -0.2 + 1.99j, -0.2 - 1.99j], 1.0),
    ([-1], [0, -10, -30], 1.0),
    ([], [0, -2, -2], 1.0),
    ([-1 + 2j, -1 - 2j], [0, 0, -10], 1.0),
    ([], [-1, -5, -10], 50.0),
]


def _text(coefficients) -> str:
    n = len(coefficients) - 1
    return "(" + " + ".join(f"({float(c)!r})*s^{n - i}" for i, c in enumerate(coefficients)) + ")"


def _loops():
    for zeros, poles, gain in LOOPS:
        num, den = gain * np.atleast_1d(np.real(np.poly(zeros))), np.real(np.poly(poles))
        network = unity_feedback([f"{_text(num)}/{_text(den)}"], "s", 0.0)
        yield loop_model(network, "e", np.geomspace(1e-3, 1e3, 400), {}), ct.tf(num, den)


@pytest.mark.parametrize("case", range(len(LOOPS)))
def test_the_gain_for_a_crossover_puts_it_there(case):
    loop, plant = list(_loops())[case]
    for wc in (0.1, 1.0, 3.0):
        solution = gain_for_crossover(loop, wc)
        crossovers = ct.stability_margins(solution.factor * plant, returnall=True)[4]  # the gain crossovers
        assert min(abs(np.asarray(crossovers) / wc - 1)) < 1e-8, (case, wc, crossovers)


@pytest.mark.parametrize("case", range(len(LOOPS)))
def test_the_gain_for_a_phase_margin_gives_it(case):
    loop, plant = list(_loops())[case]
    for pm in (30.0, 45.0, 60.0):
        try:
            solution = gain_for_phase_margin(loop, pm)
        except EngineError as exc:
            w = np.geomspace(1e-5, 1e5, 200001)
            phase = np.degrees(np.angle(plant(1j * w)))
            assert "never reaches" in str(exc) or "smaller phase margin" in str(exc)
            if "never reaches" in str(exc):  # the phase, sampled densely, stays off -180 + PM
                assert not np.any(np.abs((phase - (pm - 180) + 180) % 360 - 180) < 0.01), (case, pm)
            continue
        _, margin, _, _, crossover, _ = ct.stability_margins(solution.factor * plant)
        assert margin == pytest.approx(pm, abs=1e-6) and crossover == pytest.approx(solution.frequency, rel=1e-8)


def test_a_phase_margin_no_gain_gives_is_refused_with_the_reason():
    loop, _ = list(_loops())[4]  # 10 (s + 0.5) / (s^2 (s + 20)): the lead lifts the phase to about -140 deg
    with pytest.raises(EngineError, match="never reaches -100 deg"):
        gain_for_phase_margin(loop, 80.0)


def test_every_gain_for_a_phase_margin_is_listed_by_frequency():
    """Issue 54: a conditionally stable loop's phase crosses -180 + PM twice; both gains
    give the margin (python-control on each scaled loop), ordered by crossover frequency."""
    from engine.design.gain_solves import phase_margin_solutions

    loop, plant = list(_loops())[0]  # 10 (s + 0.3) / (s^2 (s + 10) (s + 3)): a phase bump
    solutions = phase_margin_solutions(loop, 20.0)
    assert len(solutions) == 2 and solutions[0].frequency < solutions[1].frequency
    assert gain_for_phase_margin(loop, 20.0) == solutions[0]
    for solution in solutions:
        _, margin, _, _, crossover, _ = ct.stability_margins(solution.factor * plant)
        assert margin == pytest.approx(20.0, abs=1e-6) and crossover == pytest.approx(solution.frequency, rel=1e-8)

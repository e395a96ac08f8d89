"""A measure the loop does not have is judged by one rule (issue 37 section 1;
engine/design/measure_kinds.ABSENT): no crossing means an infinite margin (met);
no crossover means no bandwidth when |GH| < 1 everywhere (a crossover requirement
>= X unmet, <= X met) and the reverse when |GH| > 1 everywhere; no modal peak is
not above any bound; a NaN is never met.  The generic tableau (cip, compare, the
workbench) and slp's rows (and so sweeps and tolerance studies) read it alike."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.design.measure_kinds import ABSENT, absence, met
from engine.design.problem import BandValue, Condition, Grid, Problem, Target
from engine.design.tableau import tableau
from engine.slp.measures import evaluate, measure_specs
from sessions.sweeps.results import worst_case

GRID = Grid(np.geomspace(1e-3, 1e3, 400))


def problem(expression: str, targets: list[Target]) -> Problem:
    return Problem((Condition("c", unity_feedback([expression]), "e"),), (), tuple(targets), GRID)


def target(measure: str, desired: float, sense: str | None = None) -> Target:
    return Target(measure, (BandValue(0.0, np.inf, desired),), sense=sense)


def slp_rows(p: Problem) -> list[tuple[str, float, bool]]:
    specs = measure_specs(p, require_stable=False)
    values, _ = evaluate(p, p.vector(), specs)
    return [(s.kind, float(v), s.met(v)) for s, v in zip(specs, values)]


@pytest.mark.parametrize(
    "sense, met_expected",
    [(None, False), ("at_most", True)],  # wc >= 3 is unmet without bandwidth, wc <= 3 is met
)
def test_no_crossover_below_one_is_no_bandwidth(sense, met_expected):
    p = problem("0.1/(s+1)", [target("crossover_frequency", 3.0, sense)])
    (row,) = tableau(p)
    assert row.value == 0.0 and row.satisfied is met_expected and "|GH| < 1 everywhere" in row.method
    assert slp_rows(p) == [("crossover_frequency", 0.0, met_expected)]


@pytest.mark.parametrize("sense, met_expected", [(None, True), ("at_most", False)])
def test_no_crossover_above_one_is_the_reverse(sense, met_expected):
    p = problem("1000*(s+1)/(s+0.0001)", [target("crossover_frequency", 3.0, sense)])
    (row,) = tableau(p)
    assert row.value == math.inf and row.satisfied is met_expected and "|GH| > 1 everywhere" in row.method
    assert slp_rows(p) == [("crossover_frequency", math.inf, met_expected)]


def test_margins_without_their_crossings_are_infinite_and_met():
    """0.1/(s+1): no gain crossover and no phase crossing; slp lists each row, met, infinite."""
    p = problem(
        "0.1/(s+1)",
        [target("phase_margin_deg", 45.0), target("gain_margin_db", 6.0), target("delay_margin", 0.1)],
    )
    rows = slp_rows(p)
    assert rows == [
        ("phase_margin_deg", math.inf, True),
        ("gain_margin_db", math.inf, True),
        ("delay_margin", math.inf, True),
    ]


def test_a_modal_peak_that_does_not_exist_is_not_above_a_bound():
    p = problem("1/(s+1)", [target("modal_peak_db", -10.0)])
    assert slp_rows(p) == [("modal_peak_db", -math.inf, True)]


def test_every_absence_is_met_by_its_natural_sense_and_a_nan_never():
    from engine.design.measure_kinds import kind

    for name, (value, reason) in ABSENT.items():
        assert met(value, 1.0, kind(name).at_least) and reason
    assert not met(math.nan, 1.0, True) and not met(math.nan, 1.0, False) and met(math.nan, None, True)
    assert absence("crossover_frequency", np.array([0.5, 0.9]))[0] == 0.0
    assert absence("crossover_frequency", np.array([1.5, 9.0]))[0] == math.inf
    assert absence("rise_time") is None and absence("disk_margin") is None  # always defined


def test_a_tolerance_study_counts_a_nan_as_unmet_and_an_absent_margin_as_met():
    runs = [
        {"index": 0, "measures": [_row("GM2", math.inf, True), _row("OS1", 10.0, True)]},
        {"index": 1, "measures": [_row("GM2", 8.0, True), _row("OS1", math.nan, False)]},
    ]
    worst = {w["name"]: w for w in worst_case(runs)}
    assert worst["GM2"]["worst"] == 8.0 and worst["GM2"]["unmet_samples"] == 0
    assert worst["OS1"]["unmet_samples"] == 1


def _row(name: str, value: float, satisfied: bool) -> dict:
    return {
        "name": name,
        "kind": "k",
        "condition": "c",
        "value": value,
        "desired": 6.0,
        "satisfied": satisfied,
        "at_least": True,
    }


def test_slp_gives_a_nan_no_credit_in_its_figure_of_merit():
    """A NaN used to be credited its desired value (it was 'absent'); now it earns nothing."""
    from engine.slp.algorithm import Slp, SlpSettings

    stepper = Slp.bind(problem("10/(s*(s+1))", [target("phase_margin_deg", 45.0)]), SlpSettings(require_stable=False))
    assert stepper._merit(np.array([math.nan])) < stepper._merit(np.array([45.0]))


def test_an_unstable_closed_loop_tolerates_no_delay_and_has_unbounded_peaks():
    """Issue 37 section 3: the tableau and slp agree with analyze and the docs."""
    p = problem("16000/(s*(s+8)*(s+20))", [target("delay_margin", 0.1), target("sensitivity_peak", 2.0)])
    delay, ms = tableau(p)
    assert (delay.value, delay.satisfied) == (0.0, False) and "unstable" in delay.method
    assert ms.value == math.inf and not ms.satisfied
    assert slp_rows(p) == [("delay_margin", 0.0, False), ("sensitivity_peak", math.inf, False)]

"""The table of measure kinds (`engine.design.measure_kinds`): complete (every measure
a session or a problem accepts has a kind), unique short labels, and senses
that agree with how the evaluators judge real measures of a small loop."""

from __future__ import annotations

import math
from typing import get_args

import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.design.measure_kinds import (
    DOMAINS,
    MEASURE_KINDS,
    default_desired,
    kind,
    names,
    shorts,
)
from engine.design.problem import (
    AT_MOST,
    FREQUENCY_MEASURES,
    MEASURE_NAMES,
    TIME_MEASURES,
    BandValue,
    Condition,
    Grid,
    Objective,
    Parameter,
    Problem,
    Target,
    TimeResponse,
)
from engine.design.tableau import tableau
from engine.errors import EngineError
from engine.slp.measures import SHORT, evaluate, measure_specs
from engine.stepping.registry import lookup

# a type-1 loop with a lightly damped mode at 10 rad/s; stable up to K = 6
LOOP = "K/(s*(s+1)*(s+2)) * 100/(s**2 + 0.4*s + 100)"
ROBUST, AGGRESSIVE = 1.0, 4.0
STEP = TimeResponse("r", "y", horizon=60.0, points=1200)
MARGIN_MEASURES = (
    "gain_margin",
    "phase_margin",
    "stability_margin",
    "gain_margin_db",
    "phase_margin_deg",
    "attenuation_margin",
    "crossover_frequency",
    "disk_margin",
    "sensitivity_peak",
    "complementary_sensitivity_peak",
    "delay_margin",
)


def loop_problem(K: float, targets) -> Problem:
    net = unity_feedback([LOOP])
    return Problem(
        (Condition("c", net, "e"),), (Parameter("K", K),), tuple(targets), Grid(np.geomspace(0.01, 100, 400))
    )


def target(measure: str, desired: float = 0.0) -> Target:
    return Target(
        measure,
        (BandValue(0.0, np.inf, desired),),
        detect_low=5.0 if measure == "attenuation_margin" else 0.0,
        response=STEP if kind(measure).domain == "time" else None,
    )


def first_value(K: float, measure: str) -> float:
    """The measure's first tableau row (margins) or slp row (time, poles) on the loop with gain K."""
    if measure in MARGIN_MEASURES:
        return tableau(loop_problem(K, [target(measure)]))[0].value
    problem = loop_problem(K, [target(measure)])
    specs = measure_specs(problem, require_stable=False)
    return float(evaluate(problem, problem.vector(), specs)[0][0])


# -- complete and consistent -------------------------------------------------


def test_every_measure_a_session_names_has_a_kind():
    from sessions.format.schema import TargetModel

    assert set(get_args(TargetModel.model_fields["measure"].annotation)) == set(MEASURE_KINDS)


def test_every_kind_is_accepted_by_a_problem_and_others_are_refused():
    problem = loop_problem(1.0, [target(name) for name in MEASURE_KINDS])
    assert [t.measure for t in problem.targets] == list(MEASURE_NAMES)
    with pytest.raises(EngineError, match="unknown measure 'overshoot'; known: gain_margin, "):
        loop_problem(1.0, [Target("overshoot", (BandValue(0, 1, 1),))])
    with pytest.raises(EngineError, match="unknown measure 'nope'; known: .*stability_abscissa"):
        kind("nope")


def test_the_problem_constants_are_the_table():
    assert MEASURE_NAMES == names() == tuple(MEASURE_KINDS)
    assert FREQUENCY_MEASURES == names("frequency") and TIME_MEASURES == names("time")
    assert set(FREQUENCY_MEASURES) | set(TIME_MEASURES) | set(names("poles")) == set(MEASURE_KINDS)
    assert set(AT_MOST) == {n for n, k in MEASURE_KINDS.items() if not k.at_least}
    with pytest.raises(EngineError, match="unknown measure domain"):
        names("space")


def test_columns_are_well_formed():
    for name, k in MEASURE_KINDS.items():
        assert k.name == name and k.label and k.short and k.tag
        assert k.domain in DOMAINS
        assert math.isfinite(k.default_desired)
        assert (k.margin is not None) == (k.domain == "frequency")
    assert default_desired()["phase_margin_deg"] == 30.0 and shorts()["phase_margin_deg"] == "PM deg"


def test_short_labels_and_slp_tags_are_unique():
    for column in ("short", "tag", "label"):
        values = [getattr(k, column) for k in MEASURE_KINDS.values()]
        assert len(set(values)) == len(values), column
    assert SHORT["gain_margin_db"] == "GM" and SHORT["stability_abscissa"] == "STAB"  # slp's row names


# -- senses -------------------------------------------------------------------


@pytest.mark.parametrize("measure", MARGIN_MEASURES)
def test_the_tableau_judges_a_real_margin_by_the_tables_sense(measure):
    value = first_value(ROBUST, measure)
    step = 0.01 * abs(value) + 1e-3
    below = tableau(loop_problem(ROBUST, [target(measure, value - step)]))[0]
    above = tableau(loop_problem(ROBUST, [target(measure, value + step)]))[0]
    assert below.value == pytest.approx(value) and below.at_least == kind(measure).at_least
    assert below.satisfied == kind(measure).at_least  # value > desired: met only when larger is better
    assert above.satisfied == (not kind(measure).at_least)


@pytest.mark.parametrize(
    "measure",
    [
        "gain_margin",
        "phase_margin",
        "stability_margin",
        "gain_margin_db",
        "phase_margin_deg",
        "attenuation_margin",
        "overshoot_percent",
        "settling_time",
        "peak_response",
        "stability_abscissa",
        "disk_margin",
        "sensitivity_peak",
        "complementary_sensitivity_peak",
        "delay_margin",
    ],
)
def test_the_better_loop_is_better_by_the_tables_sense(measure):
    """Not a tautology: the gentler gain (K = 1, far from the K = 6 limit) is the better loop by every
    robustness measure, the modal peak and the step response's overshoot, settling and peak."""
    robust, aggressive = first_value(ROBUST, measure), first_value(AGGRESSIVE, measure)
    assert robust != pytest.approx(aggressive)
    assert (robust > aggressive) == kind(measure).at_least


def test_slp_rows_follow_the_table_and_an_explicit_sense():
    problem = loop_problem(
        ROBUST,
        [
            target("gain_margin_db"),
            target("rise_time", 1.0),
            Target("rise_time", (BandValue(0, np.inf, 1.0),), sense="at_least", response=STEP),
        ],
    )
    gm, rise, reversed_rise = measure_specs(problem, require_stable=False)
    assert (gm.at_least, rise.at_least, reversed_rise.at_least) == (True, False, True)
    assert rise.met(0.5) and not reversed_rise.met(0.5)


# -- algorithms ---------------------------------------------------------------


def test_each_algorithm_declares_the_measures_it_reads():
    """The registrations' `TargetUse` (found through the entry points), not a column here."""
    use = {name: lookup(name).targets for name in ("cip", "slp", "qcg", "projection")}
    assert use["slp"].measures == names()
    assert set(use["cip"].measures) == {
        "gain_margin",
        "phase_margin",
        "stability_margin",
        "attenuation_margin",
        "gain_margin_db",
        "phase_margin_deg",
        "disk_margin",
        "sensitivity_peak",
        "complementary_sensitivity_peak",
    }
    assert not use["qcg"].reads and not use["projection"].reads
    assert not use["qcg"].accepts("gain_margin") and not use["projection"].accepts("rise_time")
    assert use["cip"].accepts("gain_margin") and not use["cip"].accepts("rise_time")
    with pytest.raises(EngineError, match="unknown measure"):
        use["slp"].check("slp", ["gain_margins"])
    with pytest.raises(EngineError, match="unknown algorithm 'newton'"):
        lookup("newton")


def test_cip_refuses_a_measure_it_cannot_improve_naming_both():
    from engine.cip.requirements import check_targets

    with pytest.raises(EngineError, match="cip: target measure 'rise_time' is not a margin"):
        check_targets(loop_problem(1.0, [target("gain_margin"), target("rise_time")]))
    check_targets(loop_problem(1.0, [target(name) for name in lookup("cip").targets.measures]))


def test_qcg_refuses_targets_it_would_ignore():
    from engine.qcg.setup import cascade_problem

    problem = loop_problem(1.0, [target("phase_margin_deg")])
    problem = Problem(
        problem.conditions, problem.parameters, problem.targets, problem.grid, Objective("quadratic_cost")
    )
    with pytest.raises(EngineError, match="qcg: target measure 'phase_margin_deg' is not read by qcg"):
        cascade_problem(problem)

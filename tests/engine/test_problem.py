"""The problem's free vector: shared and per-condition parameters, sign bounds."""

from __future__ import annotations

import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.design.problem import Condition, Grid, Parameter, Problem
from engine.errors import EngineError


def problem():
    net = unity_feedback(["K*(1+T*s)/(s*(s+2))"])
    conditions = (Condition("low q", net, "e"), Condition("high q", net, "e"))
    params = (
        Parameter("K", (1.0, 2.0), minimum=-5.0, sign="positive"),
        Parameter("T", 0.1, maximum=1.0),
        Parameter("unused", 3.0, free=False),
    )
    return Problem(conditions, params, (), Grid(np.geomspace(0.1, 10, 5)))


def test_vector_round_trip_and_values_per_condition():
    p = problem()
    assert p.free_slots() == [(0, 0), (0, 1), (1, None)]
    np.testing.assert_array_equal(p.vector(), [1.0, 2.0, 0.1])
    q = p.with_vector([3.0, 4.0, 0.2])
    assert q.condition_values(1) == {"K": 4.0, "T": 0.2, "unused": 3.0}
    assert q.named() == {"K": [3.0, 4.0], "T": 0.2, "unused": 3.0}
    assert p.vector().tolist() == [1.0, 2.0, 0.1]  # the original is unchanged


def test_named_and_vector_from_round_trip():
    p = problem()
    x = [3.0, 4.0, 0.2]
    named = p.named(x)
    assert named == {"K": [3.0, 4.0], "T": 0.2, "unused": 3.0}
    np.testing.assert_array_equal(p.vector_from(named), x)
    assert p.named(p.vector_from(named)) == named
    np.testing.assert_array_equal(p.vector_from({"T": 0.5}), [1.0, 2.0, 0.5])  # the rest: start values
    with pytest.raises(EngineError, match="unknown parameter 'nope'"):
        p.vector_from({"nope": 1.0})
    with pytest.raises(EngineError, match="'K': expected 2 values"):
        p.vector_from({"K": [1.0]})


def test_condition_values_with_x_or_named_match_a_copy():
    p = problem()
    x = [3.0, 4.0, 0.2]
    for c in range(2):
        assert p.condition_values(c, x) == p.with_vector(x).condition_values(c)
        assert p.condition_values(c, named=p.named(x)) == p.with_vector(x).condition_values(c)
    assert p.condition_values(0) == {"K": 1.0, "T": 0.1, "unused": 3.0}
    assert p.condition_values(1, named={"T": 0.7}) == {"K": 2.0, "T": 0.7, "unused": 3.0}
    assert p.condition_values(0, x) is not p.condition_values(0, x)  # a fresh dict each call
    with pytest.raises(EngineError, match="not both"):
        p.condition_values(0, x, named={"T": 0.7})


def test_bounds_include_the_sign_constraint():
    lower, upper = problem().bounds()
    np.testing.assert_array_equal(lower, [0.0, 0.0, -np.inf])
    np.testing.assert_array_equal(upper, [np.inf, np.inf, 1.0])


def test_inconsistent_problems_are_refused():
    net = unity_feedback(["K/s"])
    with pytest.raises(EngineError, match="no parameter defined for K"):
        Problem((Condition("c", net, "e"),), (), (), Grid(np.ones(1)))
    with pytest.raises(EngineError, match="2 values for 1 conditions"):
        Problem((Condition("c", net, "e"),), (Parameter("K", (1.0, 2.0)),), (), Grid(np.ones(1)))


def test_unknown_measures_are_refused_when_the_problem_is_made():
    from engine.design.problem import BandValue, Target

    net = unity_feedback(["2/s"])
    with pytest.raises(EngineError, match="unknown measure 'overshoot'"):
        Problem((Condition("c", net, "e"),), (), (Target("overshoot", (BandValue(0, 1, 1),)),), Grid(np.ones(1)))

"""A design's loop is formed once (engine/loop/design.py): the margins, the closed-loop
poles with their polish, the root locus and the pole-zero map of one design all read
the same pole-zero form, realizations and blocks' poles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback
from engine.closed_loop.root_locus import pole_zero_map, root_locus
from engine.loop import design as design_module
from engine.loop.design import design

# a loop that is not one cascade (its pole-zero form comes from the realization: the costly path)
LOOP = ["K*(1 + T1*s)/(1 + T2*s)", "4/(s*(s + 2)*(s**2 + 0.4*s + 9))"]
PARAMS = {"K": 2.0, "T1": 1.0, "T2": 0.1}


@pytest.fixture
def counted(monkeypatch):
    """Calls of the form-making functions the design's cached forms wrap."""
    counts = {"pole_zero": 0, "loop_realization": 0, "realize": 0, "factored": 0}

    def counting(name, function):
        def wrapped(*args, **kwargs):
            counts[name] += 1
            return function(*args, **kwargs)

        return wrapped

    monkeypatch.setattr(design_module, "zpk_evaluator", counting("pole_zero", design_module.zpk_evaluator))
    monkeypatch.setattr(design_module, "loop_realization", counting("loop_realization", design_module.loop_realization))
    monkeypatch.setattr(design_module, "realize", counting("realize", design_module.realize))
    monkeypatch.setattr(design_module, "block_pole_zero", counting("factored", design_module.block_pole_zero))
    return counts


def test_margins_poles_locus_and_map_of_one_design_form_its_loop_once(counted):
    network = unity_feedback(LOOP)
    omega = np.geomspace(1e-2, 1e2, 400)
    result = analyze(network, "e", omega, PARAMS)
    assert result.closed_loop_poles and result.margins.phase  # the analyses ran
    root_locus(network, "e", PARAMS, "gain", polished=False)
    root_locus(network, "e", PARAMS, "gain", polished=True)
    pole_zero_map(network, "e", PARAMS)
    analyze(network, "e", np.geomspace(1e-3, 1e3, 200), PARAMS)  # another grid: the same design
    blocks = len(network.entries)
    assert counted["pole_zero"] == 1 and counted["realize"] == 1, counted
    assert counted["loop_realization"] <= 1, counted
    assert counted["factored"] <= blocks, counted  # each block's poles once


def test_a_new_parameter_value_is_a_new_design(counted):
    network = unity_feedback(LOOP)
    first = design(network, PARAMS)
    assert design(network, dict(PARAMS)) is first
    second = design(network, PARAMS | {"K": 3.0})
    assert second is not first and second.params["K"] == 3.0
    assert first.loop("e") is first.loop("e")


def test_a_designs_margins_are_found_once_for_the_tableau_and_the_plots(monkeypatch):
    """cip's tableau (`detect`, margins "fitted") and the Bode marks (`margins` of `loop_model`,
    "auto") searched one design's margins each (before: two searches a nudge, one per thread);
    one loop object per design, break and grid now carries them.  Other values, another grid
    or another break are a loop of their own."""
    import engine.margins.search as search_module
    from engine.cip.requirements import detect
    from engine.loop.responses import loop_model
    from sessions.store import load_session

    problem = load_session(Path(__file__).resolve().parents[2] / "sessions/examples/report003_lag_lead.json").problem
    searched, search = [], search_module._searched
    monkeypatch.setattr(search_module, "_searched", lambda *a, **k: searched.append(1) or search(*a, **k))
    x, c = problem.vector(), problem.conditions[0]
    detect(problem, x, "auto")
    loop = loop_model(c.network, c.break_at, problem.grid.omega, problem.condition_values(0, x))
    assert len(searched) == 1
    marks = search_module.margins(loop)
    assert len(searched) == 1 and marks.phase
    assert search_module.margins(loop, attenuation_above=1.0) is not marks and len(searched) == 2
    values = problem.condition_values(0, x)
    moved = {name: value * 1.01 for name, value in values.items()}
    assert loop_model(c.network, c.break_at, problem.grid.omega, dict(values)) is loop
    for other in (
        loop_model(c.network, c.break_at, problem.grid.omega, moved),
        loop_model(c.network, c.break_at, np.geomspace(1e-3, 1e3, 10), values),
    ):
        assert other is not loop
    grid = np.geomspace(1e-2, 1e2, 50)
    kept = loop_model(c.network, c.break_at, grid, values)
    grid *= 2.0  # the caller's grid changed in place: the loop kept is still of the grid it was made on
    assert loop_model(c.network, c.break_at, grid, values) is not kept and kept.omega[0] == 1e-2


def test_a_design_without_a_parameters_value_names_it():
    """An exact network's design (and its loop model) asked without a parameter's value: a
    ParameterError naming the parameter, not a bare KeyError."""
    from engine.errors import ParameterError
    from engine.loop.responses import loop_model

    network = unity_feedback(["k", "1/(s*(s + T))"])
    with pytest.raises(ParameterError, match="'T'"):
        design(network, {"k": 1.0})
    with pytest.raises(ParameterError, match="'k'"):
        loop_model(network, "e", np.logspace(-1, 1, 20), {"T": 1.0})


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_a_design_at_a_value_that_is_not_finite_names_the_parameter(value):
    """A design asked at a parameter value that is not finite is refused where it is asked, by
    the network's one parameter check (before, a design was made at NaN and each consumer failed
    its own way later)."""
    from engine.errors import ParameterError

    network = unity_feedback(["k", "1/(s*(s + T))"])
    with pytest.raises(ParameterError, match="'T' is not finite"):
        design(network, {"k": 1.0, "T": value})

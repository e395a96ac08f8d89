"""slp polishes a design whose gain margin is infinite (issue 51, section 1): the loops of
textbook problems (a gain, a PI or a lead on a type-1 second-order plant) have no phase
crossing, so a gain-margin target is met and absent.  It used to freeze slp: its figure of
merit counted the absent row at its cap, which inflated the relative improvement a trial must
show (0.1 % of the merit) above what a small step of the crossover earned, and every trial
was refused.  Each case's reachability is checked by a reference written here: the loop
sampled densely over the parameter box with numpy, margins read off the samples."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sessions.new.templates import new_session
from sessions.runner import run_session
from sessions.store import parse_session
from tests.engine.brute_force import Plant, SmallProblem, compensator_polynomials, measures

TEMPLATE_TARGETS = [  # the templates' own: PM >= 45 deg (a degree weighs a fifth), GM >= 6 dB
    {"measure": "phase_margin_deg", "bands": [{"desired": 45.0}], "scale": 0.2},
    {"measure": "gain_margin_db", "bands": [{"desired": 6.0}], "scale": 1.0},
]
CASES = [
    # compensator, plants gain/(s (s + a)) as (gain, a), start, bounds, crossover wanted
    ("gain", [(1.0, 1.0)], {"K": 0.05}, {"K": (0.01, 10.0)}, 0.9),
    ("gain", [(1.0, 1.0), (1.2, 1.5)], {"K": 0.05}, {"K": (0.01, 10.0)}, 0.7),
    ("pi", [(1.0, 1.0)], {"K": 0.05, "Ti": 10.0}, {"K": (0.01, 10.0), "Ti": (2.0, 100.0)}, 0.4),
    (
        "lead",
        [(1.0, 1.0)],
        {"K": 0.05, "T1": 1.0, "T2": 0.1},
        {"K": (0.01, 100.0), "T1": (0.05, 10.0), "T2": (0.05, 10.0)},
        2.0,
    ),
    (
        "lead",
        [(1.0, 1.0), (1.5, 2.0)],
        {"K": 0.05, "T1": 1.0, "T2": 0.1},
        {"K": (0.01, 100.0), "T1": (0.05, 10.0), "T2": (0.05, 10.0)},
        1.5,
    ),
]


@pytest.mark.parametrize("compensator, plants, start, bounds, crossover", CASES)
def test_slp_polishes_past_an_infinite_gain_margin(compensator, plants, start, bounds, crossover):
    plants = [Plant(gain, 1, a, 0.0, None) for gain, a in plants]
    targets = [*TEMPLATE_TARGETS, {"measure": "crossover_frequency", "bands": [{"desired": crossover}]}]
    problem = SmallProblem(0, compensator, plants, targets, start, bounds)
    last = run_session(problem.session(), until_done=True, autosave=False)[-1]
    for row in last.measures:  # every requirement met, the gain margins judged on their absence
        if row.kind == "crossover_frequency":  # driven to its SPEC, the LP's vertex may land a hair under it
            assert row.value >= crossover * (1 - 1e-3), (row.condition, row.value, last.reason)
        else:
            assert row.satisfied, (row.name, row.condition, row.value, last.reason)
    design = {k: float(v) for k, v in last.parameters.items()}
    c_num, c_den = compensator_polynomials(compensator, design)
    for plant in plants:  # the reference agrees: a crossover at least the one wanted, PM >= 45, no phase crossing
        p_num, p_den = plant.polynomials()
        found = measures(np.convolve(c_num, p_num), np.convolve(c_den, p_den))
        assert found is not None and found["crossover_frequency"] >= crossover * 0.99
        assert found["phase_margin_deg"] >= 45.0 * 0.99 and found["gain_margin_db"] == math.inf


def test_an_absent_crossover_is_steered_by_its_surrogate():
    """|GH| < 1 everywhere: the crossover is absent (0, unmet); slp steers log |GH(j 1)| toward
    0 dB and ends with the crossover it asked for (the LP had no row and did not move before)."""
    data = new_session("1/((s+1)*(s+2))", "gain", "slp")
    problem = data["problem"]
    problem["parameters"][0].update(value=0.01, min=1e-4, max=100.0)
    problem["targets"] = [{"measure": "crossover_frequency", "bands": [{"desired": 1.0}]}]
    run = run_session(parse_session(json.dumps(data), "test", Path(".")), until_done=True, autosave=False)
    crossover = next(row for row in run[-1].measures if row.kind == "crossover_frequency")
    # the reference: |K/((j+1)(j+2))| = K / sqrt(10) at 1 rad/s, so a crossover >= 1 needs K >= sqrt(10)
    assert crossover.value >= 1.0 * (1 - 1e-3), run[-1].reason
    assert float(run[-1].parameters["K"]) >= math.sqrt(10.0) * (1 - 1e-3)

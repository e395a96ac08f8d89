"""Many samples' realizations of one network at once (issue 53: a batched realization of the
whole diagram): every sample's closed loop from `engine.loop.batch_realization` is the one
`closed_loop_realization` makes for it, on the launch vehicle's three conditions (parallel
sensor paths, the bending filter's WF, ZF and the attitude path's TA drawn) and on the
lag-lead (a biproper compensator: I - D differs by sample); an entry of higher degree has no
batched realization."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from engine.loop.batch_realization import batch_closed_loop
from engine.loop.design import closed_loop_realization
from engine.model.blocks import ExpressionTransfer
from engine.model.network import Network
from sessions.build import build_problem
from sessions.store import validated_model

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _problem(name: str):
    return build_problem(validated_model(json.loads((EXAMPLES / name).read_text())).problem, EXAMPLES)


def _columns(values: dict, drawn: tuple[str, ...], count: int, rng: np.random.Generator) -> dict:
    columns = {name: np.full(count, value) for name, value in values.items()}
    for name in drawn:
        columns[name] = values[name] * (1 + rng.uniform(-0.1, 0.1, count))
    return columns


def _equal_per_sample(condition, columns: dict) -> None:
    stacked = batch_closed_loop(condition.network, condition.break_at, columns)
    assert stacked is not None
    for k in range(len(next(iter(columns.values())))):
        params = {name: float(values[k]) for name, values in columns.items()}
        ss = closed_loop_realization(condition.network, condition.break_at, params)
        assert (stacked.inputs, stacked.outputs) == (ss.inputs, ss.outputs)
        for got, want in zip((stacked.A[k], stacked.B[k], stacked.C[k], stacked.D[k]), (ss.A, ss.B, ss.C, ss.D)):
            assert got.shape == want.shape
            assert np.max(np.abs(got - want), initial=0.0) <= 1e-12 * np.max(np.abs(want), initial=0.0)


@pytest.mark.parametrize("c", [0, 1, 2])
def test_the_launch_vehicle_s_conditions(c):
    problem = _problem("coebra_launch_vehicle.json")
    columns = _columns(problem.condition_values(c), ("WF", "ZF", "TA"), 30, np.random.default_rng(c))
    _equal_per_sample(problem.conditions[c], columns)


def test_a_biproper_compensator_s_feedthrough_varies():
    problem = _problem("coebra_lag_lead.json")
    columns = _columns(problem.condition_values(0), ("T1", "T2"), 30, np.random.default_rng(7))
    _equal_per_sample(problem.conditions[0], columns)


def test_an_entry_of_higher_degree_has_none():
    """The lag-lead's plant with a drawn gain, K*16000/(s (s+8)(s+20)): a third-order ratio, which
    `realize` factors by its roots per sample."""
    problem = _problem("coebra_lag_lead.json")
    network = problem.conditions[0].network
    entries = tuple(
        replace(e, transfer=ExpressionTransfer("K*16000/(s*(s+8)*(s+20))")) if "16000" in e.transfer.text else e
        for e in network.entries
    )
    assert entries != network.entries
    changed = Network(network.signals, network.inputs, entries)
    columns = {**_columns(problem.condition_values(0), (), 3, np.random.default_rng(0)), "K": np.array([1, 1.1, 0.9])}
    assert batch_closed_loop(changed, problem.conditions[0].break_at, columns) is None


def test_a_static_gain_drawn():
    """A varied entry of degree 0 (the two-path autopilot's gain KA: no states, its gain the
    feedthrough) raised IndexError in the batch's canonical section."""
    problem = _problem("two_path_autopilot.json")
    columns = _columns(problem.condition_values(0), ("KA",), 20, np.random.default_rng(3))
    _equal_per_sample(problem.conditions[0], columns)

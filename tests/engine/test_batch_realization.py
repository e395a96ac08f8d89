"""Many samples' realizations of one network at once (issue 53: a batched realization of the
whole diagram): every sample's closed loop from `engine.loop.batch_realization` is the one
`closed_loop_realization` makes for it, on the launch vehicle's three conditions (parallel
sensor paths, the bending filter's WF, ZF and the attitude path's TA drawn) and on the
lag-lead (a biproper compensator: I - D differs by sample) and on a loop in z's w-plane form; an
entry of higher degree has no batched realization."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from engine.loop.batch_realization import (
    SharedStateSpace,
    batch_closed_loop,
    batch_loop_realization,
    closed_of,
    samples,
)
from engine.loop.design import closed_loop_realization
from engine.model.blocks import ExpressionTransfer
from engine.model.network import Network
from engine.slp.batch_rows import batch_time_rows
from engine.slp.measures import measure_specs
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


def test_a_loop_in_z_is_realized_in_its_w_plane_form():
    """Kuo's loop in z (T = 0.5 s) as the problem holds it (variable w, each z written
    (1 + w)/(1 - w)): its compensator's (1 - w) factors divided out as `realize` divides them,
    every sample's closed loop the per-sample one, with the sample time."""
    problem = _problem("coebra_kuo_z.json")
    condition = problem.conditions[0]
    assert (condition.network.variable, condition.network.sample_time) == ("w", 0.5)
    columns = _columns(problem.condition_values(0), ("T1", "T2"), 30, np.random.default_rng(5))
    _equal_per_sample(condition, columns)
    stacked = batch_closed_loop(condition.network, condition.break_at, columns)
    assert stacked is not None and stacked.sample_time == 0.5 and stacked.A.shape[1] == 4  # 1 + 3 states
    assert {one.sample_time for one in samples(stacked)} == {0.5}


def _response(ss, k: int, w: np.ndarray, i: int, j: int) -> np.ndarray:
    """Sample ``k``'s transfer from input ``j`` to output ``i`` at s = j w, by a dense solve."""
    x = np.linalg.solve(1j * w[:, None, None] * np.eye(ss.A.shape[1]) - ss.A[k], ss.B[k][:, j])
    return x @ ss.C[k][i] + ss.D[k][i, j]


def _matched(got: np.ndarray, want: np.ndarray) -> float:
    """The largest distance of each of ``want`` to its nearest in ``got`` (each taken once)."""
    left, worst = list(got), 0.0
    for value in want:
        nearest = min(range(len(left)), key=lambda i: abs(left[i] - value))
        worst = max(worst, abs(left.pop(nearest) - value))
    return worst


@pytest.mark.parametrize("c", [0, 1, 2])
def test_blocks_that_move_alike_share_their_states(c):
    """The launch vehicle's bending modes each held by a gyro's, a rate gyro's and an
    accelerometer's block fed by the actuator: shared, 16 states in place of 28, every transfer
    (the disturbance to the angle of attack, the broken loop) the full realization's at every
    frequency, the 12 states left out kept as hidden poles: the full loop's eigenvalues are the
    shared one's and the hidden ones."""
    problem = _problem("coebra_launch_vehicle.json")
    condition = problem.conditions[c]
    columns = _columns(problem.condition_values(c), ("WF", "ZF", "TA"), 5, np.random.default_rng(c))
    full = batch_loop_realization(condition.network, condition.break_at, columns)
    shared = batch_loop_realization(condition.network, condition.break_at, columns, shared=True)
    assert isinstance(shared, SharedStateSpace) and (shared.A.shape[1], full.A.shape[1]) == (16, 28)
    assert shared.hidden.shape == (5, 12)
    w = np.geomspace(0.01, 200.0, 40)
    k = condition.network.signal(condition.break_at)
    closed, whole = (closed_of(condition.network, condition.break_at, ss) for ss in (shared, full))
    assert isinstance(closed, SharedStateSpace) and np.array_equal(closed.hidden, shared.hidden)
    alpha, gust = whole.outputs.index("alpha"), whole.inputs.index("alpha_w")
    for sample in range(5):
        for got_ss, want_ss, i, j in ((shared, full, k, -1), (closed, whole, alpha, gust)):
            want = _response(want_ss, sample, w, i, j)
            assert np.max(np.abs(_response(got_ss, sample, w, i, j) - want) / np.abs(want)) <= 1e-10
        poles = np.linalg.eigvals(whole.A[sample])
        every = np.concatenate([np.linalg.eigvals(closed.A[sample]), closed.hidden[sample]])
        assert _matched(every, poles) <= 1e-9 * np.max(np.abs(poles))


def test_blocks_of_other_dynamics_or_inputs_keep_their_states():
    """The lag-lead: no two blocks move alike; shared or not, the same realization."""
    problem = _problem("coebra_lag_lead.json")
    condition = problem.conditions[0]
    columns = _columns(problem.condition_values(0), ("T1", "T2"), 4, np.random.default_rng(3))
    full = batch_loop_realization(condition.network, condition.break_at, columns)
    shared = batch_loop_realization(condition.network, condition.break_at, columns, shared=True)
    assert shared.hidden.shape == (4, 0)
    for got, want in zip((shared.A, shared.B, shared.C, shared.D), (full.A, full.B, full.C, full.D)):
        assert np.array_equal(got, want)


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


def test_the_stability_rows_read_the_poles_of_the_states_left_out():
    """Mode 1 damped 100 times less (zeta = 1e-4: its copies' poles, which no input reaches, the
    closed loop's rightmost, Re = -0.001): every time and stability row from the shared
    realizations is the full ones' (`engine.slp.batch_rows`)."""
    text = (EXAMPLES / "coebra_launch_vehicle.json").read_text().replace("0.22*s+121", "0.002*s+121")
    problem = build_problem(validated_model(json.loads(text)).problem, EXAMPLES)
    specs = measure_specs(problem)
    xs = np.tile(problem.vector(), (3, 1))
    xs[:, 0] *= [0.9, 1.0, 1.1]
    rows = []
    for shared in (False, True):
        stacks = {}
        for c, condition in enumerate(problem.conditions):
            values = [problem.condition_values(c, x) for x in xs]
            columns = {name: np.array([v[name] for v in values]) for name in values[0]}
            broken = batch_loop_realization(condition.network, condition.break_at, columns, shared)
            stacks[c] = (broken, closed_of(condition.network, condition.break_at, broken))
        values, ok = batch_time_rows(problem, specs, xs, stacks, stability=True)
        assert ok.all()
        rows.append(values)
    stability = [i for i, spec in enumerate(specs) if spec.kind == "stability_abscissa"]
    assert np.min(rows[0][:, stability]) == pytest.approx(0.001, rel=1e-9)
    there = ~np.isnan(rows[0])
    assert np.array_equal(there, ~np.isnan(rows[1]))
    assert np.max(np.abs(rows[1][there] - rows[0][there]) / np.abs(rows[0][there])) <= 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_block_of_several_ports_is_placed_as_realize_places_it(tmp_path, seed):
    """Random loops around a random block of two ports (parallel sensor paths, an inner loop
    through its second port, `tests.sessions.test_batch_study._random_ported_session`), every
    parameter drawn: each sample's closed loop is the one `closed_loop_realization` makes (its
    states once, the same states; before: no batched realization), and sharing leaves it as it is."""
    from tests.sessions.test_batch_study import _random_ported_session

    path = tmp_path / "ported.json"
    _random_ported_session(np.random.default_rng(seed), path)
    problem = build_problem(validated_model(json.loads(path.read_text())).problem, tmp_path)
    values = problem.condition_values(0)
    columns = _columns(values, tuple(values), 20, np.random.default_rng(seed))
    _equal_per_sample(problem.conditions[0], columns)
    condition = problem.conditions[0]
    full = batch_loop_realization(condition.network, condition.break_at, columns)
    shared = batch_loop_realization(condition.network, condition.break_at, columns, shared=True)
    assert shared.hidden.shape == (20, 0)
    for got, want in zip((shared.A, shared.B, shared.C, shared.D), (full.A, full.B, full.C, full.D)):
        assert np.array_equal(got, want)

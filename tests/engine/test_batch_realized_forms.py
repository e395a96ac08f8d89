"""The minimal pole-zero forms of loops that are not one cascade, from stacked realizations
(`engine.loop.batch_realized_forms`, issue 53): the launch vehicle's three conditions (each
bending mode held by three blocks), WF, ZF and TA drawn.  Checked against scipy's QZ of each
sample's pencil ([[A, b], [c, d]], diag(I, 0)) and eigenvalues of A (the form's roots and the
hidden poles together; python-control's minreal needs slycot, not installed) and the network's
own evaluator (GH at frequencies across the loop's band, the bending modes included)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import linalg

from engine.loop.batch_realization import batch_loop_realization
from engine.loop.batch_realized_forms import realized_forms
from engine.loop.evaluator import LoopEvaluator
from engine.loop.pole_zero import ZpkEvaluator
from engine.loop.responses import loop_model
from engine.margins.search import margins
from sessions.build import build_problem
from sessions.store import validated_model

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _stack(c: int, count: int, seed: int):
    problem = build_problem(
        validated_model(json.loads((EXAMPLES / "coebra_launch_vehicle.json").read_text())).problem, EXAMPLES
    )
    condition = problem.conditions[c]
    values = problem.condition_values(c)
    rng = np.random.default_rng(seed)
    columns = {name: np.full(count, value) for name, value in values.items()}
    for name in ("WF", "ZF", "TA"):
        columns[name] = values[name] * (1 + rng.uniform(-0.1, 0.1, count))
    ss = batch_loop_realization(condition.network, condition.break_at, columns)
    return condition, columns, ss


def _matched(a: np.ndarray, b: np.ndarray) -> float:
    """The largest relative distance from each root of ``a`` to its nearest in ``b`` (same count)."""
    assert a.size == b.size
    return max((float(np.min(np.abs(b - r)) / max(abs(r), 1.0)) for r in a), default=0.0)


@pytest.mark.parametrize("c", [0, 1, 2])
def test_the_launch_vehicle_s_minimal_forms(c):
    condition, columns, ss = _stack(c, 6, c)
    k = condition.network.signal(condition.break_at)
    found = realized_forms(ss, k)
    assert found is not None and not found.forms.odd.any()
    # 28 states: each of the three bending modes held three times, two copies hidden
    assert (found.forms.zeros.shape[1], found.forms.poles.shape[1], found.hidden.shape[1]) == (11, 16, 12)
    w = np.array([0.05, 0.3, 1.0, 2.5, 7.0, 11.3, 15.0, 23.0, 30.0, 41.0, 90.0, 400.0])
    realized = found.response(np.repeat(np.arange(6), w.size), np.tile(w, 6))[0].reshape(6, w.size)
    for s in range(6):
        A, b, cc, d = ss.A[s], ss.B[s][:, -1:], -ss.C[s][k : k + 1], -ss.D[s][k : k + 1, -1:]
        mass = np.zeros((29, 29))
        mass[:28, :28] = np.eye(28)
        qz = linalg.eigvals(np.block([[A, b], [cc, d]]), mass)
        qz = qz[np.isfinite(qz) & (np.abs(qz) < 1e6)]  # (QZ also gives one near 3e12 rad/s: an infinite one)
        hidden = found.hidden[s]
        assert _matched(np.concatenate([found.forms.zeros[s], hidden]), qz) < 1e-8
        assert _matched(np.concatenate([found.forms.poles[s], hidden]), linalg.eigvals(A)) < 1e-8
        params = {name: float(v[s]) for name, v in columns.items()}
        exact = LoopEvaluator(condition.network, condition.break_at, params)(w)[0]
        form = ZpkEvaluator(complex(found.forms.gain[s]), found.forms.zeros[s], found.forms.poles[s])(w)[0]
        assert np.max(np.abs(form - exact) / np.abs(exact)) < 1e-11
        assert np.max(np.abs(realized[s] - exact) / np.abs(exact)) < 1e-12


def test_a_sample_with_one_pair_more_is_odd():
    """TA drawn equal to TR (0.05) cancels the attitude path's pole with a zero in that sample
    alone: its form has another shape, it goes the per-loop path."""
    condition, columns, _ = _stack(0, 5, 3)
    columns["TA"][2] = columns["TR"][2]
    ss = batch_loop_realization(condition.network, condition.break_at, columns)
    found = realized_forms(ss, condition.network.signal(condition.break_at))
    assert found is not None and found.forms.odd.tolist() == [False, False, True, False, False]


def test_the_per_loop_margins_of_a_realized_form_are_the_network_s():
    """A loop's form from its realization (QZ: the launch vehicle's, 52 roots with a zero at
    3e12 rad/s) kept its own margins when it agreed with the network to 1e-11 there: GH up to
    9e-12 off the network's at the margins of switch-out.  Every margin of such a form is now
    polished on the network: GH there is the network's own."""
    condition, columns, _ = _stack(2, 12, 2)
    worst = 0.0
    for s in range(12):
        params = {name: float(v[s]) for name, v in columns.items()}
        model = loop_model(condition.network, condition.break_at, np.logspace(-2, 3, 50), params)
        found = margins(model, attenuation_above=0.0)
        every = [m for family in (found.gain, found.phase, found.attenuation) for m in family if m.frequency > 0]
        exact = model.exact(np.array([m.frequency for m in every]))[0]
        worst = max(worst, float(np.max(np.abs(np.array([m.gh for m in every]) - exact) / np.abs(exact))))
    assert worst <= 1e-15


def test_the_realizations_gh_in_passes_is_the_same(monkeypatch):
    """`RealizedForms.response` solves `POINTS` points at a time (a 2000-sample chunk's margins
    would hold 150 MB of pencils at once): passes of 5 give what one pass gives."""
    import engine.loop.batch_realized_forms as module

    condition, _, ss = _stack(1, 4, 5)
    found = realized_forms(ss, condition.network.signal(condition.break_at))
    samples, w = np.repeat(np.arange(4), 6), np.tile(np.geomspace(0.1, 60.0, 6), 4)
    whole = found.response(samples, w, slope=True)
    monkeypatch.setattr(module, "POINTS", 5)
    parts = found.response(samples, w, slope=True)
    assert np.array_equal(whole[0], parts[0]) and np.array_equal(whole[1], parts[1])

"""`qcg`'s optimizers on report 001's Appendix C sample: every cost evaluation
counted, CGFM (the report's) and L-BFGS-B (``optimizer="lbfgsb"``) against scipy's
L-BFGS-B on the same cost, exact resumption and replay, and the stop statuses."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import minimize

import engine.qcg.cost as qcg_cost
import engine.qcg.setup as qcg_setup
from engine.errors import EngineError
from engine.qcg import Qcg, QcgSettings
from engine.qcg.memory import QcgMemory
from engine.qcg.setup import cascade_problem
from engine.stepping.driver import iterate
from engine.stepping.protocol import State, Status
from sessions.runner import replay, run_session
from sessions.store import load_session, save_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
SAMPLE_F = 0.3122836  # Appendix C sample with the clean Table I (docs/algorithms/qcg.md)


@pytest.fixture(scope="module")
def sample():
    return load_session(EXAMPLES / "seidel_inlet_pi.json").problem


def run(problem, **settings):
    return [r for _, r in iterate(Qcg.bind(problem, QcgSettings(**settings)), max_iter=1000)]


def scipy_lbfgsb(problem):
    """scipy's own L-BFGS-B on F(p b0) with the analytic gradient, p = b/b0 >= 1e-6."""
    cascade, b0 = cascade_problem(problem), problem.vector()
    names = list(cascade.names)

    def cost(p):
        result = cascade.cost(dict(zip(names, p * b0)), gradient=True)
        return result.F, np.array([result.gradient[n] for n in names]) * b0

    return minimize(cost, np.ones(b0.size), jac=True, method="L-BFGS-B", bounds=[(1e-6, None)] * b0.size), b0


@pytest.mark.parametrize("optimizer", ["cgfm", "lbfgsb"])
def test_every_cost_evaluation_is_counted(sample, monkeypatch, optimizer):
    """Each call of the cost formula (`quadratic_cost`, wherever it is called from) is counted: the
    open-loop reference, the start, every trial, every new point; the records make none of their own."""
    calls = []
    real = qcg_cost.quadratic_cost

    def counted(*args, **options):
        calls.append(options.get("gradient", args[5] if len(args) > 5 else True))
        return real(*args, **options)

    for module in (qcg_cost, qcg_setup):  # the cost's only two callers
        monkeypatch.setattr(module, "quadratic_cost", counted)
    records = run(sample, optimizer=optimizer)
    last = records[-1]
    assert last.counters["evaluations"] == len(calls) and last.counters["gradients"] == sum(calls)
    assert last.counters["KNT"] == len(calls) - 1  # all but the open-loop reference
    assert last.extra["F"] == pytest.approx(SAMPLE_F, abs=5e-8) and last.status is Status.CONVERGED
    counts = [r.counters["evaluations"] for r in records]
    assert all(b > a for a, b in zip(counts, counts[1:])) or optimizer == "cgfm"  # CGFM restarts reuse b


def test_cgfm_evaluations_are_those_of_the_listing(sample):
    """CGFM's path is the listing's: 19 line searches as before; the search's evaluations are KNT's
    former 94 less the 5 re-evaluations at an unchanged point after a failed contraction."""
    last = run(sample)[-1]
    assert last.counters["KOUNT"] == 19 and last.counters["KNT"] == 94 - 5
    assert last.counters["evaluations"] <= 102  # the report's count (Appendix C)


def test_lbfgsb_matches_scipys_on_the_same_cost(sample):
    """Same F as scipy's L-BFGS-B (its pgtol test), within a few evaluations of it."""
    reference, b0 = scipy_lbfgsb(sample)
    records = run(sample, optimizer="lbfgsb")
    last = records[-1]
    assert reference.success and last.status is Status.CONVERGED
    assert last.extra["F"] == pytest.approx(reference.fun, rel=1e-9)
    assert [last.parameters["b1"], last.parameters["b21"]] == pytest.approx(reference.x * b0, rel=1e-4)
    assert last.counters["evaluations"] <= reference.nfev + 5
    assert len(records) == last.counters["KOUNT"] <= 20  # one iteration per step


@pytest.mark.parametrize("optimizer", ["cgfm", "lbfgsb"])
def test_a_stored_state_resumes_exactly(sample, optimizer):
    """Stop after 4 steps, store the state as JSON, read it back, go on: the records are those of the
    run without the stop, field for field."""
    whole = [r.to_json() for r in run(sample, optimizer=optimizer)]
    steps = list(iterate(Qcg.bind(sample, QcgSettings(optimizer=optimizer)), max_iter=4))
    stored = json.loads(json.dumps(steps[-1][0].to_json(), allow_nan=False))
    state = State.from_json(stored, QcgMemory)
    assert state.memory.pairs_s if optimizer == "lbfgsb" else state.memory.direction
    fresh = Qcg.bind(sample, QcgSettings(optimizer=optimizer))  # as a session resumes: a new stepper
    rest = [r.to_json() for _, r in iterate(fresh, max_iter=1000, state=state)]
    assert [r.to_json() for _, r in steps] + rest == whole


def test_an_lbfgsb_session_replays(tmp_path):
    """A saved session of the lbfgsb optimizer replays: every field of every record and the state."""
    shutil.copy(EXAMPLES / "seidel_inlet_table1.csv", tmp_path)
    data = json.loads((EXAMPLES / "seidel_inlet_pi.json").read_text())
    data["algorithm"]["settings"]["optimizer"] = "lbfgsb"
    path = tmp_path / "lbfgsb.json"
    path.write_text(json.dumps(data))
    session = load_session(path)
    run_session(session, 5, autosave=False)
    save_session(session)
    result = replay(load_session(path))
    assert result.ok, result


def test_a_stop_without_decrease_is_no_further_improvement(sample):
    """With L-BFGS-B's own tests off (gtol = ftol = 0) the run ends where no line search along the
    projected gradient lowers F: "no further improvement", not "converged"."""
    last = run(sample, optimizer="lbfgsb", gtol=0.0, ftol=0.0, limit=200)[-1]
    assert last.status is Status.NO_IMPROVEMENT and "no decrease" in last.reason
    assert last.extra["F"] == pytest.approx(SAMPLE_F, abs=5e-8)


def test_a_zero_gradient_is_no_improvement_for_cgfm_and_converged_for_lbfgsb(sample):
    """With no disturbance and no noise F = 0 for every b: CGFM has no descent direction (the report's
    test SIZE < EPS is not met: no further improvement); L-BFGS-B's gradient test is met."""
    objective = replace(sample.objective, tables={}, options=dict(sample.objective.options, disturbance_amplitude=0.0))
    flat = replace(sample, objective=objective)
    cgfm, lbfgsb = run(flat)[-1], run(flat, optimizer="lbfgsb")[-1]
    assert cgfm.status is Status.NO_IMPROVEMENT and "zero gradient" in cgfm.reason
    assert lbfgsb.status is Status.CONVERGED and "projected gradient" in lbfgsb.reason


def test_cgfm_convergence_is_the_reports_test(sample):
    last = run(sample)[-1]
    assert last.status is Status.CONVERGED and last.extra["size"] < 1e-5 and "IER = 0" in last.reason


def test_optimizer_and_its_settings_are_checked():
    with pytest.raises(EngineError, match="optimizer must be 'cgfm' or 'lbfgsb'"):
        QcgSettings(optimizer="bfgs")
    with pytest.raises(EngineError, match="pairs >= 1"):
        QcgSettings(optimizer="lbfgsb", pairs=0)


def test_lbfgsb_memory_rejects_malformed_pairs(sample):
    state = list(iterate(Qcg.bind(sample, QcgSettings(optimizer="lbfgsb")), max_iter=3))[-1][0]
    data = state.to_json()
    data["memory"]["pairs_y"] = data["memory"]["pairs_y"][:-1]
    with pytest.raises(EngineError, match=r"qcg memory\.pairs_y: expected \d+ items"):
        State.from_json(data, QcgMemory)
    data = state.to_json()
    data["memory"]["last"]["gradient"] = [1.0]
    with pytest.raises(EngineError, match=r"qcg memory\.last\.gradient: expected 2 items, got 1"):
        State.from_json(data, QcgMemory)

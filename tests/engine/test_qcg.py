"""`qcg` (report 001): the cost against the report's sample and printout, the
gradient against central differences, the search against Appendix C."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from engine.model.blocks import ControllerFactor, ExpressionTransfer, controller_transfer
from engine.qcg import Qcg, QcgSettings
from engine.qcg.cost import Cascade, Weights, exponential_disturbance, quadratic_cost
from engine.qcg.setup import cascade_problem
from engine.stepping.driver import iterate
from engine.stepping.protocol import Status
from sessions.store import load_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
REPORT_B = {"b1": 47.2165, "b21": 130.565}


@pytest.fixture(scope="module")
def sample():
    return load_session(EXAMPLES / "seidel_inlet_pi.json")


def test_cost_at_the_reports_optimum(sample):
    """Checked by hand against the clean table of report 001: with it, F = 0.3123, FDQ = 0.2886, FVQ = 0.02367 at the report's b;
    the listing printed F = 0.3119, FDQ = 0.2884, FVQ = 0.02352 (its data had OCR-free values we reconciled)."""
    result = cascade_problem(sample.problem).cost(REPORT_B, gradient=False)
    assert result.F == pytest.approx(0.3123, abs=5e-5)
    assert result.parts["FDQ"] == pytest.approx(0.2886, abs=5e-5)
    assert result.parts["FVQ"] == pytest.approx(0.02367, abs=5e-6)
    assert result.F == pytest.approx(0.3119, rel=0.005) and result.C == pytest.approx(result.F / (2 * np.pi))


def test_frequency_response_printout_at_3_hz(sample):
    """Appendix C, INST = 4, line 24: 3 Hz, |Y|/GA12 = 0.511, 54.77 deg, OPEN = -0.2967 - j1.729."""
    rows = cascade_problem(sample.problem).frequency_response(REPORT_B)
    row = next(r for r in rows if abs(r["hz"] - 3.0) < 1e-9)
    assert row["magnitude"] == pytest.approx(0.5111, rel=0.02)
    assert row["phase_deg"] == pytest.approx(54.77, rel=0.02)
    assert complex(row["open_real"], row["open_imag"]) == pytest.approx(complex(-0.2967, -1.729), rel=0.02)


def test_appendix_c_search(sample):
    records = [r for _, r in iterate(Qcg.bind(sample.problem, QcgSettings()), max_iter=500)]
    last = records[-1]
    assert last.status is Status.CONVERGED and "IER = 0" in last.reason
    assert last.parameters["b1"] == pytest.approx(47.2, rel=0.01)
    assert last.parameters["b21"] == pytest.approx(130.6, rel=0.01)
    assert last.extra["F"] == pytest.approx(0.3119, rel=0.005)
    assert last.extra["parts"]["FDQ"] == pytest.approx(0.2884, rel=0.015)
    assert last.extra["parts"]["FVQ"] == pytest.approx(0.02352, rel=0.015)
    assert last.counters["KNT"] <= 150 and last.objective == pytest.approx(last.extra["F"] / (2 * np.pi))


def test_iteration_limit_and_expansion_failure(sample):
    limited = [r for _, r in iterate(Qcg.bind(sample.problem, QcgSettings(limit=3)), max_iter=100)]
    assert limited[-1].status is Status.ITERATION_LIMIT and limited[-1].counters["KOUNT"] == 3
    # constant scaling by the initial estimates: the step keeps improving past 15 doublings (IER = 2)
    constant = [r for _, r in iterate(Qcg.bind(sample.problem, QcgSettings(scaling="initial")), max_iter=100)]
    assert constant[-1].status is Status.FAILED and "IER = 2" in constant[-1].reason


def _rational_cascade(points: int = 60, w_max: float = 400.0, damping: float = 0.3) -> Cascade:
    def plant(w):
        s = 1j * w
        g1 = 2.0 / (s / 30 + 1)
        return g1, g1 * 1.5 / ((s / 80) ** 2 + 2 * damping * s / 80 + 1), 1.2 / (s / 150 + 1)

    w = np.geomspace(0.5, w_max, points)
    return Cascade(w, *plant(w), 1e-4 * np.ones(w.size), exponential_disturbance(w, 2.0, 10.0, 1.0), plant)


EVERY_KIND = controller_transfer(
    "k",
    -1,
    [
        ControllerFactor("zero", b="bz"),
        ControllerFactor("pole", b="bp"),
        ControllerFactor("complex_zero", damping="zc", frequency="wc"),
        ControllerFactor("complex_pole", damping="zq", frequency="wq"),
    ],
)
VALUES = {"k": 3.0, "bz": 12.0, "bp": 90.0, "zc": 0.4, "wc": 40.0, "zq": 0.7, "wq": 120.0, "k2": 0.05, "b2": 25.0}


@pytest.mark.parametrize("tabulated", [False, True])
def test_gradient_matches_central_differences_for_every_parameter_kind(sample, tabulated):
    h2 = ExpressionTransfer("k2*(s/b2 + 1)")
    if tabulated:
        cascade, h1 = cascade_problem(sample.problem).cascade, EVERY_KIND
    else:
        cascade, h1 = _rational_cascade(), EVERY_KIND
    weights = Weights(q1=1.0, q2=1e-4, r1=0.3, r2=1e-5, rsnat=0.0)  # no resonance splitting: a smooth sum
    names = tuple(VALUES)
    analytic = quadratic_cost(cascade, h1, h2, VALUES, weights, names=names).gradient

    def F(values):
        return quadratic_cost(cascade, h1, h2, values, weights, gradient=False).F

    for name in names:
        h = 1e-3 * VALUES[name]

        def central(step):
            return (F(VALUES | {name: VALUES[name] + step}) - F(VALUES | {name: VALUES[name] - step})) / (2 * step)

        richardson = (4 * central(h / 2) - central(h)) / 3
        assert analytic[name] == pytest.approx(richardson, rel=1e-6, abs=1e-12), name


def test_resonance_refinement_brings_the_sum_closer_to_the_integral():
    """Near a resonance the listing splits intervals in IN parts; on a rational plant with exact controller
    values the refined sum is nearer a dense-grid sum than the plain one."""
    coarse = _rational_cascade(points=25, damping=0.1)
    h1 = ExpressionTransfer("k*(s/bz + 1)/s")
    params = {"k": 5.0, "bz": 20.0}
    plain = quadratic_cost(coarse, h1, None, params, Weights(q1=1, subdivisions=1), gradient=False)
    refined = quadratic_cost(coarse, h1, None, params, Weights(q1=1, subdivisions=3), gradient=False)
    dense = quadratic_cost(
        _rational_cascade(points=4000, damping=0.1), h1, None, params, Weights(q1=1, subdivisions=1), gradient=False
    )
    assert refined.refined_intervals > 0
    assert abs(refined.F - dense.F) < abs(plain.F - dense.F)


def test_penalty_sweep_trades_output_against_its_rate(sample):
    """Report 001, Figure 4(a): as q2 grows the output rate falls and the output rises."""
    from engine.qcg.tradeoff import penalty_sweep

    points = penalty_sweep(sample.problem, QcgSettings(), "q2", [0.0, 1e-5, 1e-4, 1e-3])
    x1 = [p.averaged_squares["x1_normalized"] for p in points]
    rate = [p.averaged_squares["x1_rate_normalized"] for p in points]
    assert all(p.status == "converged" for p in points)
    assert x1 == sorted(x1) and rate == sorted(rate, reverse=True)
    assert points[2].parameters["b1"] == pytest.approx(47.41, rel=0.01)  # the session's own q2: Appendix C

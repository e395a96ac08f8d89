"""`cip` (report 000): gradients against central differences and the report's
closed form, every termination status, the ratchet on both bundled examples."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from engine.cip import Cip, CipSettings
from engine.cip.direction import gradient_rows
from engine.cip.present import cip_report_text
from engine.cip.requirements import Requirement
from engine.design.problem import BandValue, Condition, Grid, Parameter, Point, Problem, Target
from engine.errors import EngineError
from engine.loop.responses import open_loop
from engine.model.blocks import ExpressionTransfer, FrequencyTable, TabulatedTransfer, polynomial_transfer
from engine.model.network import Block, Junction, block_diagram
from engine.stepping.driver import iterate
from engine.stepping.protocol import Status
from engine.stepping.registry import lookup
from sessions.runner import replay, run_session
from sessions.store import load_session
from tests.engine.cip_report_partials import report_partials

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"

# two channels, two sub-compensators each: (numerator, denominator) ascending, by parameter name
SUBS = {
    "a": [(["a1x0", "a1x1"], ["a1y0", "a1y1", "a1y2"]), (["a2x0", "a2x1", "a2x2"], ["a2y0", "a2y1"])],
    "b": [(["b1x0", "b1x1"], ["b1y0", "b1y1"]), (["b2x0"], ["b2y0", "b2y1", "b2y2"])],
}
VALUES = {
    "a1x0": 1.0,
    "a1x1": 2.5,
    "a1y0": 1.0,
    "a1y1": 0.8,
    "a1y2": 0.05,
    "a2x0": 100.0,
    "a2x1": 6.0,
    "a2x2": 7.5,
    "a2y0": 100.0,
    "a2y1": 10.0,
    "b1x0": 0.5,
    "b1x1": 0.3,
    "b1y0": 1.0,
    "b1y1": 0.2,
    "b2x0": 10.0,
    "b2y0": 10.0,
    "b2y1": 1.2,
    "b2y2": 0.09,
}
W_TABLE = np.geomspace(0.05, 50.0, 401)


def _table_channel():
    s = 1j * W_TABLE
    return TabulatedTransfer(FrequencyTable(W_TABLE, 2.0 / (s * s - 0.04) * (1 + 0.5 * s) / (1 + s / 20)))


def two_channel_problem(targets: tuple[Target, ...] = ()) -> Problem:
    """Report 000's Figure 1 with a tabulated and a rational channel."""
    blocks = [
        Block("a.response", "e", "a.theta", _table_channel(), "a"),
        Block("b.response", "e", "b.theta", ExpressionTransfer("5*s/((s+2)*(s+30))"), "b"),
    ]
    for ch, subs in SUBS.items():
        signal = f"{ch}.theta"
        for k, (num, den) in enumerate(subs, start=1):
            blocks.append(Block(f"{ch}.{k}", signal, f"{ch}.{k}.out", polynomial_transfer(num, den, "ascending"), ch))
            signal = f"{ch}.{k}.out"
    junctions = [
        Junction("sum", "c", ((1.0, "a.2.out"), (1.0, "b.2.out"))),
        Junction("err", "e", ((1.0, "r"), (-1.0, "c"))),
    ]
    network = block_diagram(blocks, junctions, ["r"])
    params = tuple(Parameter(n, v, minimum=0.0) for n, v in VALUES.items())
    targets = targets or (Target("stability_margin", (BandValue(0, np.inf, 0.5),)),)
    return Problem((Condition("c", network, "e"),), params, targets, Grid(W_TABLE))


def _sub_response(ch: str, k: int, params: dict, w: float) -> complex:
    num, den = SUBS[ch][k]
    s = 1j * w
    return sum(params[c] * s**i for i, c in enumerate(num)) / sum(params[c] * s**i for i, c in enumerate(den))


def _channel_response(problem: Problem, ch: str, w: float, params: dict) -> complex:
    """This channel's compensated open loop alone: theta_k/R times its cascade."""
    theta = _table_channel().table.interpolate([w])[0] if ch == "a" else 5 * (1j * w) / ((1j * w + 2) * (1j * w + 30))
    return theta * _sub_response(ch, 0, params, w) * _sub_response(ch, 1, params, w)


@pytest.mark.parametrize("k", [37, 180, 333])
@pytest.mark.parametrize("point", [complex(-1, 0), complex(-7, -3), complex(0, 0)])
def test_gradient_matches_differences_and_report_closed_form(k, point):
    problem = two_channel_problem()
    w = float(W_TABLE[k])
    gh = open_loop(problem.conditions[0].network, "e", [w], VALUES, sensitivities=False).value[0]
    requirement = Requirement(
        "f", "S", "stability_margin", 0, w, abs(1 + gh), 0.5, 0.0, 0.5, 1.0, (Point(point, "push"),), gh
    )
    analytic = gradient_rows(problem, problem.vector(), [requirement]).gradients[0]
    names = [p.name for p in problem.parameters]

    def distance(values: dict) -> float:
        v = open_loop(problem.conditions[0].network, "e", [w], values, sensitivities=False).value[0]
        return abs(v - point) ** 2

    def central(name: str, h: float) -> float:
        return (distance(VALUES | {name: VALUES[name] + h}) - distance(VALUES | {name: VALUES[name] - h})) / (2 * h)

    for j, name in enumerate(names):
        h = 1e-3 * abs(VALUES[name])  # Richardson-extrapolated central differences: error O(h^4)
        richardson = (4 * central(name, h / 2) - central(name, h)) / 3
        assert analytic[j] == pytest.approx(richardson, rel=1e-6, abs=1e-9 * np.abs(analytic).max())
    # the report's closed form, sub-compensator by sub-compensator: A + jB holds everything else
    for ch, subs in SUBS.items():
        own = _channel_response(problem, ch, w, VALUES)
        for q, (num, den) in enumerate(subs):
            cd = own / _sub_response(ch, q, VALUES, w)
            dx, dy = report_partials(-point + gh - own, cd, [VALUES[c] for c in num], [VALUES[c] for c in den], w)
            for value, c in zip(np.concatenate([dx, dy]), num + den):
                assert value == pytest.approx(analytic[names.index(c)], rel=1e-6, abs=1e-9 * np.abs(analytic).max())


def _loop_problem(
    expression: str, params: dict, free: tuple[str, ...], targets: tuple[Target, ...], side: str | None = None
) -> Problem:
    blocks = [Block("loop", "e", "c", ExpressionTransfer(expression))]
    if side:
        blocks.append(Block("side", "c", "y", ExpressionTransfer(side)))
    network = block_diagram(blocks, [Junction("err", "e", ((1.0, "r"), (-1.0, "c")))], ["r"])
    parameters = tuple(Parameter(n, v, minimum=0.0, free=n in free) for n, v in params.items())
    return Problem((Condition("c", network, "e"),), parameters, targets, Grid(np.geomspace(0.01, 100, 400)))


GM = Target("gain_margin", (BandValue(0, np.inf, 0.9),))
PM = Target("phase_margin", (BandValue(0, np.inf, 1.5),))


def _first(problem: Problem, settings: CipSettings = CipSettings()):
    stepper = Cip.bind(problem, settings)
    return stepper.step(stepper.init())


def test_more_active_requirements_than_coefficients_is_theorem_2():
    problem = _loop_problem("K/(s*(s+1)*(s+2))", {"K": 3.0}, ("K",), (GM, PM))
    state, record = _first(problem, CipSettings(tracking=False))
    assert record.status is Status.INFEASIBLE and state.status is Status.INFEASIBLE
    assert record.extra["termination"] == "theorem2" and "Theorem 2" in record.reason


def test_beyond_theorem_2_a_least_squares_compromise_raises_the_sum_and_says_so():
    """Both margins unmet, one coefficient: the report stops; with `tracking` (the default) the
    compromise lowers K, which raises both (K = 6 is the loop's stability limit)."""
    problem = _loop_problem("K/(s*(s+1)*(s+2))", {"K": 3.0}, ("K",), (GM, PM))
    state, record = _first(problem)
    assert record.status is Status.RUNNING and record.parameters["K"] < 3.0
    assert record.extra["direction"] == "the least-squares compromise"
    assert all(m["after"] > m["before"] for m in record.extra["matched"])
    assert "DIRECTION: THE LEAST-SQUARES COMPROMISE (NOT THE REPORT'S)" in cip_report_text(record)


def test_a_lone_gain_steers_its_phase_margin_with_the_crossover_moving():
    """PM unmet on K/(s (s+1)^2): the report's row holds the crossover's frequency, where raising K
    pushes GH away from -1, while the phase margin at the moved crossover falls; every trial was
    rejected.  The rows with the crossing moving lower K, and PM rises (closed form below)."""
    target = Target("phase_margin_deg", (BandValue(0, np.inf, 40.0),))
    problem = _loop_problem("K/(s*(s+1)^2)", {"K": 1.5}, ("K",), (target,))
    stepper = Cip.bind(problem, CipSettings())
    state, records = stepper.init(), []
    while not state.status.finished and len(records) < 50:
        state, record = stepper.step(state)
        records.append(record)
    assert state.status is Status.CONVERGED, records[-1].reason
    K = records[-1].parameters["K"]
    wc = brentq(lambda w: K - w * (1 + w * w), 1e-6, 10.0)  # |K / (jw (jw+1)^2)| = 1
    assert 180 - 90 - 2 * np.degrees(np.arctan(wc)) >= 40.0 - 1e-9
    assert any(r.extra.get("direction") == "the direction with the crossings moving" for r in records)


def test_parallel_gradients_are_linearly_dependent():
    problem = _loop_problem("K1*K2/(s*(s+1)*(s+2))", {"K1": 1.5, "K2": 2.0}, ("K1", "K2"), (GM, PM))
    _, record = _first(problem)
    assert record.status is Status.NO_IMPROVEMENT and record.extra["termination"] == "dependent"


def test_a_coefficient_outside_the_loop_gives_a_zero_gradient():
    problem = _loop_problem("3/(s*(s+1)*(s+2))", {"a": 1.0}, ("a",), (GM,), side="a/(s+1)")
    _, record = _first(problem)
    assert record.status is Status.NO_IMPROVEMENT and record.extra["termination"] == "zero_gradient"
    assert "margin 1 (G" in record.reason


def test_iteration_limit_and_met_requirements():
    # only K varies: with T free too, the fixed-frequency gradient of report 000 lowers T, which moves
    # the phase crossover to where |GH| is larger (the report's Figure 16 trap)
    problem = _loop_problem("K*(1+T*s)/(s*(s+1)*(s+2))", {"K": 3.0, "T": 0.1}, ("K",), (GM,))
    limited = list(iterate(Cip.bind(problem, CipSettings(max_iterations=2, max_step=0.01)), max_iter=10))
    assert [r.status for _, r in limited] == [Status.RUNNING, Status.ITERATION_LIMIT]
    assert "the last step 0.01 (the maximum 0.01): 1 requirement(s) unmet" in limited[-1][1].reason
    done = list(iterate(Cip.bind(problem, CipSettings(max_step=0.2)), max_iter=200))
    assert done[-1][1].status is Status.CONVERGED and done[-1][1].extra["unmet"] == 0


def test_settings_are_checked():
    for bad in ({"mode": "fastest"}, {"min_step": 1.0, "max_step": 0.1}, {"growth": 0.5}, {"detection": "magic"}):
        with pytest.raises(EngineError):
            CipSettings(**bad)
    with pytest.raises(EngineError, match="not a margin"):
        Cip.bind(
            replace(
                _loop_problem("3/(s+1)", {"K": 1.0}, ("K",), (GM,)),
                targets=(Target("crossover_frequency", (BandValue(0, np.inf, 1.0),)),),
            ),
            CipSettings(),
        )


def test_refined_detection_matches_grid_detection_to_grid_accuracy():
    problem = _loop_problem("K*(1+T*s)/(s*(s+1)*(s+2))", {"K": 3.0, "T": 0.1}, ("K", "T"), (GM, PM))
    grid_rows = _first(problem)[1].measures
    exact_rows = _first(problem, CipSettings(detection="refined"))[1].measures
    assert [r.kind for r in grid_rows] == [r.kind for r in exact_rows]
    for g, e in zip(grid_rows, exact_rows):
        assert g.frequency == pytest.approx(e.frequency, rel=0.03)


@pytest.fixture(scope="module")
def example_runs():
    runs = {}
    for name in ("cip_launch_vehicle", "cip_dual_channel"):
        session = load_session(EXAMPLES / f"{name}.json")
        runs[name] = (session, run_session(session, until_done=True, autosave=False))
    return runs


@pytest.mark.parametrize("name", ["cip_launch_vehicle", "cip_dual_channel"])
def test_examples_ratchet_and_end_with_fewer_unmet_targets(example_runs, name):
    session, records = example_runs[name]
    assert session.model.algorithm.settings["mode"] == "tifr"
    for record in records:
        for pair in record.extra.get("matched", []):
            if pair["active_after"]:
                better = pair["after"] >= pair["before"] if pair["kind"] != "A" else pair["after"] <= pair["before"]
                assert better, (record.iteration, pair)
    start, end = records[0].extra["unmet_start"], records[-1].extra["unmet"]
    assert end < start
    first = Cip.bind(session.problem, lookup("cip").settings(**session.model.algorithm.settings)).init()
    assert records[-1].extra["best"]["smallest_stability_margin"] >= first.memory.best.smallest
    assert records[-1].status is (Status.CONVERGED if name == "cip_launch_vehicle" else Status.STEP_BELOW_MINIMUM)


def test_launch_vehicle_tableau_starts_like_table_1(example_runs):
    session, _ = example_runs["cip_launch_vehicle"]
    state = Cip.bind(session.problem, lookup("cip").settings(**session.model.algorithm.settings)).init()
    rows = state.memory.requirements
    assert [r.kind for r in rows[:4]] == ["G", "P", "P", "S"]
    assert rows[3].value == rows[0].value and rows[3].desired == 0.505  # INCGMS copy (Table 1, no. 4)
    assert rows[0].frequency / (2 * np.pi) < 0.1 and 1.0 < rows[1].frequency / (2 * np.pi) < 1.4


def test_example_replays(example_runs, tmp_path):
    session, _ = example_runs["cip_launch_vehicle"]
    assert replay(session).ok


def _numbers(text: str) -> np.ndarray:
    return np.array(
        [
            [float(v) for v in line.split(",")]
            for line in text.splitlines()
            if line and (line[0].isdigit() or line[0] in "+-.")
        ],
        dtype=float,
    )


def test_examples_are_generated_by_their_script(tmp_path):
    from sessions.examples.launch_vehicles import write_examples

    write_examples(tmp_path)
    for name in ("cip_launch_vehicle.csv", "cip_dual_channel.csv"):
        # the same table to the last digits printed (the last of 13 may differ with the BLAS build)
        made, bundled = ((tmp_path / name).read_text(), (EXAMPLES / name).read_text())
        assert [line for line in made.splitlines() if line.startswith("#") or not line[0].isdigit()] == [
            line for line in bundled.splitlines() if line.startswith("#") or not line[0].isdigit()
        ]
        np.testing.assert_allclose(_numbers(made), _numbers(bundled), rtol=1e-11, atol=1e-14)
    for name in ("cip_launch_vehicle.json", "cip_dual_channel.json"):
        assert json.loads((tmp_path / name).read_text()) == json.loads((EXAMPLES / name).read_text())


def test_without_the_guard_met_margins_slip_on_the_dual_channel_example():
    """The report's caveat (chapter VII): TIFR ratchets active margins only, so met ones can slip."""
    session = load_session(EXAMPLES / "cip_dual_channel.json")
    settings = dict(session.model.algorithm.settings, guard_band=0.0, keep_met=False)
    records = [r for _, r in iterate(Cip.bind(session.problem, CipSettings(**settings)), max_iter=300)]
    assert records[-1].extra["unmet"] > records[0].extra["unmet_start"]

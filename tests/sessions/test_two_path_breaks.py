"""A target read at another loop break than the design's (issue 57: `"break": NAME` on a target).
A small two-path autopilot (attitude and rate paths summed into the actuator command dc, an
attitude that integrates the rate of a first-order body) with breaks dc, u_att and u_rate; the
loop at u_att with the rate path closed is, independently, python-control's
-KA/s * feedback(B A, R, sign=+1) (A the actuator, B the body, R the rate path: the summing
junction adds, the actuator's minus sign makes it negative feedback).  slp's row PM1@u_att, its
analytic partials, its run meeting the target and the replay are checked against it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from engine.design.tableau import tableau
from engine.errors import EngineError
from engine.slp.measures import evaluate, measure_specs
from engine.slp.partials import jacobian
from sessions.errors import SessionError
from sessions.examples.coebra_launch_vehicle import _block  # a diagram's expression block
from sessions.runner import replay, run_session
from sessions.store import load_session, save_session

control = pytest.importorskip("control")


def document(targets: list[dict] | None = None) -> dict:
    plant = {
        "format": "diagram",
        "inputs": ["d"],
        "blocks": [
            _block("actuator", "dc", "delta", "-10/(s+10)"),
            _block("body", "m", "q", "4/(s+0.5)"),
            _block("attitude", "q", "theta", "1/s"),
            _block("attitude path", "theta", "u_att", "KA"),
            _block("rate path", "q", "u_rate", "KR/(1+0.05*s)"),
        ],
        "junctions": [
            {"name": "moment", "output": "m", "plus": ["delta", "d"]},
            {"name": "autopilot", "output": "dc", "plus": ["u_att", "u_rate"]},
        ],
    }
    stamp = "2026-12-04T00:00:00+00:00"
    return {
        "schema_version": 2,
        "provenance": {"loopcraft_version": "0.1.0", "created": stamp, "modified": stamp},
        "notes": "",
        "algorithm": {"name": "slp", "settings": {}},
        "records": [],
        "current_iteration": 0,
        "state": None,
        "problem": {
            "grid": {"unit": "rad/s", "start": 0.01, "stop": 100.0, "points": 300, "spacing": "log"},
            "parameters": [
                {"name": "KA", "value": 1.0, "min": 0.1, "max": 20.0},
                {"name": "KR", "value": 0.1, "min": 0.02, "max": 10.0},
            ],
            "targets": targets
            if targets is not None
            else [
                {"measure": "phase_margin_deg", "bands": [{"desired": 40.0}]},
                {"measure": "phase_margin_deg", "break": "u_att", "bands": [{"desired": 50.0}]},
            ],
            "conditions": [
                {
                    "name": "cruise",
                    "break_at": "dc",
                    "breaks": ["dc", "u_att", "u_rate"],
                    "variable": "s",
                    "plant": plant,
                }
            ],
        },
    }


def loop_at_u_att(ka: float, kr: float):
    """The loop at u_att, the rate path closed (module docstring), by python-control."""
    s = control.tf("s")
    actuator, body, rate = -10 / (s + 10), 4 / (s + 0.5), kr / (1 + 0.05 * s)
    return -ka / s * control.feedback(body * actuator, rate, sign=1)


def phase_margin(L) -> tuple[float, float]:
    """(PM deg, crossover rad/s) of a loop with one gain crossover, by python-control."""
    _, pm, _, _, wc, _ = control.stability_margins(L)
    return pm, wc


@pytest.fixture
def session(tmp_path):
    path = tmp_path / "two_paths.json"
    path.write_text(json.dumps(document()))
    return load_session(path)


def test_a_row_at_a_break_is_named_by_it_and_read_on_that_loop(session):
    problem = session.problem
    specs = measure_specs(problem)
    assert [s.name for s in specs] == ["PM1", "PM1@u_att", "STAB"]
    values, frequencies = evaluate(problem, problem.vector(), specs)
    pm, wc = phase_margin(loop_at_u_att(1.0, 0.1))
    assert values[1] == pytest.approx(pm, abs=1e-9) and frequencies[1] == pytest.approx(wc, rel=1e-9)
    assert values[0] != pytest.approx(values[1], abs=0.1)  # the primary break's loop is another
    rows = {r.name: r for r in tableau(problem)}  # the generic tableau (cip's, the comparisons') reads it too
    assert rows["PM1@u_att"].value == pytest.approx(pm, abs=1e-9)


def test_slp_s_partials_at_a_break_are_the_loop_s(session):
    """The analytic row of PM1@u_att against central differences of python-control's PM."""
    problem = session.problem
    specs = measure_specs(problem)
    x = problem.vector()
    values, frequencies = evaluate(problem, x, specs)
    J, how = jacobian(problem, x, specs, values, frequencies)
    assert how[1] == "analytic"
    names = [problem.parameters[i].name for i, _ in problem.free_slots()]
    for j, name in enumerate(names):
        h = 1e-6 * max(abs(x[j]), 1.0)
        up, down = dict(zip(names, x)), dict(zip(names, x))
        up[name] += h
        down[name] -= h
        slope = (
            phase_margin(loop_at_u_att(up["KA"], up["KR"]))[0] - phase_margin(loop_at_u_att(down["KA"], down["KR"]))[0]
        ) / (2 * h)
        assert J[1, j] == pytest.approx(slope, rel=1e-5, abs=1e-6), name


def test_slp_meets_a_target_at_a_second_break_and_the_run_replays(session, tmp_path):
    problem = session.problem
    specs = measure_specs(problem)
    values, _ = evaluate(problem, problem.vector(), specs)
    assert not specs[1].met(values[1])  # PM1@u_att: 14.6 deg at the start
    run_session(session, until_done=True, autosave=False)
    last = session.model.records[-1]
    row = next(m for m in last["measures"] if m["name"] == "PM1@u_att")
    assert row["satisfied"] and all(m["satisfied"] for m in last["measures"])
    pm, wc = phase_margin(loop_at_u_att(last["parameters"]["KA"], last["parameters"]["KR"]))
    assert row["value"] == pytest.approx(pm, abs=1e-9) and pm >= 50.0
    assert row["frequency"] == pytest.approx(wc, rel=1e-9)
    save_session(session, tmp_path / "ran.json")
    assert replay(load_session(tmp_path / "ran.json")).ok


@pytest.mark.parametrize(
    "target, message",
    [
        (
            {"measure": "phase_margin_deg", "break": "u_pitch", "bands": [{"desired": 50.0}]},
            "problem.targets[0].break: 'u_pitch' is not a break of condition 'cruise' (its breaks: dc, u_att, u_rate)",
        ),
        (
            {"measure": "stability_abscissa", "break": "u_att", "bands": [{"desired": 0.0}]},
            "problem.targets[0].break: a stability_abscissa target is read on the whole closed loop, not at a loop break",
        ),
        (
            {"measure": "multi_loop_disk_margin", "break": "u_att", "bands": [{"desired": 0.3}]},
            "problem.targets[0].break: a multi_loop_disk_margin target is read at every break of its conditions "
            "at once, not at one",
        ),
    ],
)
def test_a_break_that_is_not_the_condition_s_is_refused_with_its_path(tmp_path, target, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(document([target])))
    with pytest.raises(SessionError) as found:
        load_session(path)
    assert message in str(found.value)


def test_an_algorithm_that_reads_the_design_s_break_only_refuses_a_target_at_another(session):
    """slp and cip read targets at any break; an algorithm (a plug-in) that does not say so refuses them."""
    from engine.cip.requirements import TARGETS as CIP
    from engine.design.measure_kinds import TargetUse
    from engine.slp.measures import TARGETS as SLP

    SLP.check_targets("slp", session.problem.targets)
    CIP.check_targets("cip", session.problem.targets)
    primary_only = TargetUse(measures=("phase_margin_deg",))
    with pytest.raises(EngineError, match=r"plug: target 1 \(phase_margin_deg\) is read at the loop break 'u_att'"):
        primary_only.check_targets("plug", session.problem.targets)


def test_cip_meets_a_target_at_a_second_break_and_the_run_replays(tmp_path, capsys):
    """cip's requirement rows at u_att are read on the loop broken there (row 2@u_att), its gradient
    rows too: PM@u_att >= 45 (14.6 deg at the start) met, the row equal to python-control's."""
    data = document(
        [
            {"measure": "phase_margin_deg", "bands": [{"desired": 30.0}]},
            {"measure": "phase_margin_deg", "break": "u_att", "bands": [{"desired": 45.0}]},
        ]
    )
    data["algorithm"] = {"name": "cip", "settings": {}}
    path = tmp_path / "cip.json"
    path.write_text(json.dumps(data))
    session = load_session(path)
    run_session(session, until_done=True, autosave=False)
    last = session.model.records[-1]
    rows = {m["name"]: m for m in last["measures"]}
    assert list(rows) == ["1", "2@u_att"] and all(m["satisfied"] for m in rows.values())
    pm, wc = phase_margin(loop_at_u_att(last["parameters"]["KA"], last["parameters"]["KR"]))
    assert rows["2@u_att"]["value"] == pytest.approx(pm, abs=1e-9) and pm >= 45.0
    assert rows["2@u_att"]["frequency"] == pytest.approx(wc, rel=1e-9)
    before = phase_margin(loop_at_u_att(1.0, 0.1))[0]
    assert before < 45.0 and rows["1"]["value"] != pytest.approx(rows["2@u_att"]["value"], abs=0.1)
    save_session(session, tmp_path / "ran.json")
    assert replay(load_session(tmp_path / "ran.json")).ok
    from tui.cli import main

    assert main(["report", str(tmp_path / "ran.json")]) == 0  # report 000's listing names the break
    listing = capsys.readouterr().out
    assert re.search(r"PHASE MARGIN NO\.   2 = .* MARGIN TYPE = P   AT BREAK u_att", listing), listing


def _loops_by_python_control(ka: float, kr: float) -> dict:
    """The loop at each break, every other loop closed, by python-control's `feedback`."""
    s = control.tf("s")
    actuator, body, rate, attitude = -10 / (s + 10), 4 / (s + 0.5), kr / (1 + 0.05 * s), ka / s
    return {
        "dc": -(attitude + rate) * body * actuator,
        "u_att": -attitude * control.feedback(body * actuator, rate, sign=1),
        "u_rate": -rate * control.feedback(body * actuator, attitude, sign=1),
    }


def _loop_matrix(omega: float, ka: float, kr: float) -> np.ndarray:
    """L(j omega) at the breaks (dc, u_att, u_rate) all cut at once: L = -R, R the returns (written out)."""
    s = 1j * omega
    plant = -10 / (s + 10) * 4 / (s + 0.5)  # dc -> q
    returns = np.array([[0, 1, 1], [ka / s * plant, 0, 0], [kr / (1 + 0.05 * s) * plant, 0, 0]])
    return -returns


def _mu(omega: float, ka: float, kr: float, start: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """(mu of M = S - I/2 (skew 0) for three scalar complex blocks, the log-scales found): the D-scaled
    upper bound, which equals mu for up to three blocks, minimized by scipy from ``start``."""
    from scipy.optimize import minimize

    m = np.linalg.inv(np.eye(3) + _loop_matrix(omega, ka, kr)) - 0.5 * np.eye(3)

    def scaled(logd: np.ndarray) -> float:
        d = np.exp(np.concatenate([[0.0], logd]))
        return float(np.linalg.norm(d[:, None] * m / d[None, :], 2))

    found = minimize(
        scaled, np.zeros(2) if start is None else start, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-14}
    )
    return found.fun, found.x


def _multi_loop_alpha(ka: float, kr: float) -> tuple[float, float]:
    """(1 / max over omega of mu, the frequency of the max): mu on a grid of 161 points from 0.01 to
    100 rad/s, its largest refined by Brent's bounded search."""
    from scipy.optimize import minimize_scalar

    grid, scales, mus = np.geomspace(0.01, 100, 161), None, []
    for x in grid:  # each frequency's scales start from the last's
        mu, scales = _mu(x, ka, kr, scales)
        mus.append(mu)
    peak = grid[int(np.argmax(mus))]
    found = minimize_scalar(lambda x: -_mu(x, ka, kr)[0], bounds=(peak / 1.06, peak * 1.06), method="bounded")
    return -1 / found.fun, found.x


def test_slp_meets_a_multi_loop_disk_margin_target_and_the_run_replays(tmp_path):
    """A target on every break at once (alpha >= 0.55, 0.111 at the start) beside the two phase margins."""
    targets = document()["problem"]["targets"] + [{"measure": "multi_loop_disk_margin", "bands": [{"desired": 0.55}]}]
    path = tmp_path / "together.json"
    path.write_text(json.dumps(document(targets)))
    session = load_session(path)
    run_session(session, until_done=True, autosave=False)
    last = session.model.records[-1]
    row = next(m for m in last["measures"] if m["name"] == "MDM1")
    assert row["satisfied"] and all(m["satisfied"] for m in last["measures"])
    alpha, frequency = _multi_loop_alpha(last["parameters"]["KA"], last["parameters"]["KR"])
    assert row["value"] == pytest.approx(alpha, rel=1e-5) and alpha >= 0.55
    assert row["frequency"] == pytest.approx(frequency, rel=1e-3)
    save_session(session, tmp_path / "ran.json")
    assert replay(load_session(tmp_path / "ran.json")).ok


def _table(text: str, header: str) -> list[list[str]]:
    """The Markdown table whose header row starts with ``header``: its body rows' cells."""
    lines = text.splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith(f"| {header} |"))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split(" | ")])
    return rows


def test_the_report_gives_each_break_s_margins_and_the_multi_loop_disk_margin(session, tmp_path):
    """The report's per-break table (every crossing, to its 6 digits) against python-control's
    `stability_margins` of each loop, the disk margin against dense sampling of |S - 1/2|, and the
    multi-loop disk margin against mu computed here (scipy's D-scales on a grid, refined)."""
    from tui.cli import main

    assert main(["report", str(session.path), "--format", "md", "--out", str(tmp_path / "out")]) == 0
    text = (tmp_path / "out" / "two_paths.md").read_text()
    rows = {r[0]: r for r in _table(text, "break")}
    assert list(rows) == ["dc", "u_att", "u_rate"]
    w = np.geomspace(1e-2, 1e3, 400_001)
    for name, L in _loops_by_python_control(1.0, 0.1).items():
        gms, pms, _, wpcs, wgcs, _ = control.stability_margins(L, returnall=True)
        reported_g = sorted(tuple(float(x) for x in cell.split(" at ")[::-1]) for cell in rows[name][1].split("; "))
        reported_p = sorted(tuple(float(x) for x in cell.split(" at ")[::-1]) for cell in rows[name][2].split("; "))
        # python-control lists u_rate's L(0) = 0 (the attitude loop closed) as a phase crossing at 0 rad/s with an
        # infinite gain margin: no crossing of the negative real axis, not one loopcraft lists
        expected_g = sorted((w, 20 * np.log10(g)) for w, g in zip(wpcs, gms) if np.isfinite(g))
        assert np.array(reported_g) == pytest.approx(np.array(expected_g), rel=1e-5), name
        assert np.array(reported_p) == pytest.approx(np.array(sorted(zip(wgcs, pms))), rel=1e-5), name
        assert float(rows[name][3]) == pytest.approx(max(wgcs), rel=1e-5), name  # one crossover each here
        sampled = 1 / np.max(np.abs(1 / (1 + L(1j * w)) - 0.5))
        alpha = float(rows[name][4].split()[1])
        assert alpha == pytest.approx(sampled, rel=1e-5), name
    together = dict(_table(text, "multi-loop disk margin"))
    alpha, frequency = _multi_loop_alpha(1.0, 0.1)
    assert float(together["alpha"]) == pytest.approx(alpha, rel=1e-5)
    assert float(together["worst frequency"].split()[0]) == pytest.approx(frequency, rel=1e-3)
    assert together["certified bracket"].endswith("(certified)")


@pytest.mark.parametrize("algorithm, row", [("slp", "PM1@u_att"), ("cip", "2@u_att")])
def test_a_tolerance_study_reports_the_rows_at_a_break_and_adopts_their_worst(tmp_path, capsys, algorithm, row):
    """A serial study of KA +-10 %: the row at u_att is there under its name, its worst value is
    python-control's PM of the loop at u_att for the worst sample's drawn KA, and --adopt-worst
    names it whole (PM1@u_att, PM1@u_att@cruise: its '@' is the break's, not a condition's)."""
    from tui.cli import main

    data = document()
    data["algorithm"] = {"name": algorithm, "settings": {}}
    for which in (row, f"{row}@cruise"):
        path = tmp_path / f"{algorithm}_{which.count('@')}.json"
        path.write_text(json.dumps(data))
        argv = ["sweep", str(path), "--tolerance", "KA=+-10%", "--samples", "6", "--serial", "--json"]
        status = main([*argv, "--adopt-worst", which])
        out, err = capsys.readouterr()
        assert status == 0, err
        worst = next(r for r in json.loads(out)["worst_case"] if r["name"] == row)
        assert worst["condition"] == "cruise" and worst["samples"] == 6
        pm, _ = phase_margin(loop_at_u_att(worst["worst_parameters"]["KA"], 0.1))
        assert worst["worst"] == pytest.approx(pm, abs=1e-9)
        adopted = load_session(path).problem.named()
        assert adopted["KA"] == pytest.approx(worst["worst_parameters"]["KA"], rel=1e-15)


def test_the_bundled_two_path_example_says_what_it_does():
    """`sessions/examples/two_path_autopilot.json` is this module's autopilot with its example's
    targets: its notes' start figures are the loops at each break (checked against python-control
    above, `loop_at_u_att`), and slp meets every target, as the notes say, and replays."""
    path = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "two_path_autopilot.json"
    data = json.loads(path.read_text())
    assert data["problem"]["conditions"] == document()["problem"]["conditions"]
    session = load_session(path)
    pm, _ = phase_margin(loop_at_u_att(1.0, 0.1))
    assert f"{pm:.1f} deg at u_att" in data["notes"]
    records = run_session(session, until_done=True, autosave=False)
    assert all(row.satisfied for row in records[-1].measures)
    assert f"in {len(records)} iterations" in data["notes"]
    assert replay(session).ok

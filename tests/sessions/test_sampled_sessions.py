"""Conditions in z with a sample time: the bundled Kuo example designed in z, checked against
the unit circle sampled densely (written here), python-control's discrete margins, and the
w-plane example where the bilinear map says the numbers must agree; and what a z condition
refuses, by name."""

from __future__ import annotations

import copy
import json
import math
import shutil
from pathlib import Path

import control
import numpy as np
import pytest
from scipy.optimize import brentq

from engine.analysis import analyze
from sessions.errors import SessionError
from sessions.store import load_session, parse_session
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"

T = 0.5
PLANT_NUM = 0.13 * 3 * np.polymul([1, 1.31], [1, 0.054])  # report 003, eq. B-3 (K = 3)
PLANT_DEN = np.polymul([1, 0], [1, -1.368, 0.368])  # z (z - 1)(z - 0.368)


def _compensator(t1: float, t2: float) -> tuple[np.ndarray, np.ndarray]:
    return np.array([1 + t1, -(t1 - 1)]), np.array([1 + t2, -(t2 - 1)])


def _loop(t1: float, t2: float):
    cn, cd = _compensator(t1, t2)
    num, den = np.polymul(cn, PLANT_NUM), np.polymul(cd, PLANT_DEN)
    return lambda w: np.polyval(num, np.exp(1j * w * T)) / np.polyval(den, np.exp(1j * w * T))


def _circle_margins(t1: float, t2: float) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """(frequency, dB) of every phase crossing and (frequency, deg) of every gain crossover, from
    200 000 points of the unit circle below the Nyquist frequency, each refined by brentq."""
    L = _loop(t1, t2)
    w = np.linspace(1e-6, math.pi / T * (1 - 1e-9), 200_000)
    values = L(w)
    gains, phases = [], []
    for f, out, keep in (
        (lambda x: L(x).imag, gains, lambda v: v.real < 0),
        (lambda x: abs(L(x)) - 1.0, phases, lambda v: True),
    ):
        s = f(w)
        for i in np.flatnonzero(np.sign(s[:-1]) != np.sign(s[1:])):
            root = brentq(f, w[i], w[i + 1], xtol=1e-15, rtol=1e-15)
            v = L(root)
            if keep(v):
                out.append(
                    (root, -20 * math.log10(abs(v)) if out is gains else (math.degrees(np.angle(v)) + 360) % 360 - 180)
                )
    assert values.size
    return gains, phases


def _session_margins(path, t1: float, t2: float):
    session = load_session(path)
    problem = session.problem
    c = problem.conditions[0]
    return analyze(c.network, c.break_at, problem.grid.omega, {"T1": t1, "T2": t2})


@pytest.mark.parametrize("t1, t2", [(20.0, 20.0), (24.0, 146.03), (50.0, 195.0), (3.0, 0.5)])
def test_kuo_in_z_against_the_unit_circle_and_python_control(t1, t2):
    found = _session_margins(EXAMPLES / "coebra_kuo_z.json", t1, t2)
    gains, phases = _circle_margins(t1, t2)
    assert len(found.margins.gain) == len(gains) and len(found.margins.phase) == len(phases)
    for m, (w, db) in zip(found.margins.gain, gains):
        assert m.frequency == pytest.approx(w, rel=1e-10) and m.gain_db == pytest.approx(db, rel=1e-9, abs=1e-9)
    for m, (w, deg) in zip(found.margins.phase, phases):
        assert m.frequency == pytest.approx(w, rel=1e-10) and m.phase_deg == pytest.approx(deg, rel=1e-9, abs=1e-9)
        assert m.delay == pytest.approx(math.radians(deg) % (2 * math.pi) / w, rel=1e-12)  # seconds
    cn, cd = _compensator(t1, t2)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(
        control.tf(np.polymul(cn, PLANT_NUM), np.polymul(cd, PLANT_DEN), T)
    )
    if found.margins.phase:
        assert found.margins.crossover_frequency == pytest.approx(wgc, rel=1e-9)
        assert min(found.margins.phase, key=lambda m: abs(m.phase_deg)).phase_deg == pytest.approx(pm, rel=1e-9)
    if found.margins.gain and math.isfinite(gm):
        assert min(m.gain_db for m in found.margins.gain) == pytest.approx(20 * math.log10(gm), rel=1e-8)
    poles = np.roots(np.polyadd(np.polymul(cd, PLANT_DEN), np.polymul(cn, PLANT_NUM)))
    shown = np.array([p.value for p in found.closed_loop_poles])  # in z
    assert shown.size == poles.size  # T1 = T2 too: D(z) = 1 keeps its state, as in s (and python-control)
    assert max(np.min(np.abs(shown[:, None] - poles[None, :]), axis=1)) < 1e-9
    assert found.verdict == ("stable" if np.all(np.abs(poles) < 1) else "unstable")


def test_equal_to_the_w_plane_example_where_the_bilinear_map_says_so(tmp_path):
    """The w example's plant written in z (z = (1 + w)/(1 - w), exactly) gives the w example's
    margins at omega = (2/T) atan(nu) to rounding; the report's z plant, of which the w plant is a
    rounded image (0.13 K = 0.39 against the image's 0.3978, zeros to two digits), agrees to that
    rounding: frequencies within 2.5 %, gain margins within 0.3 dB, phase margins within 1.5 deg."""
    data = json.loads((EXAMPLES / "coebra_kuo_digital.json").read_text())
    exact = copy.deepcopy(data)
    c = exact["problem"]["conditions"][0]
    c.update(variable="z", sample_time=T)
    w = "((z-1)/(z+1))"
    for b in c["plant"]["blocks"]:
        b["transfer"]["expression"] = b["transfer"]["expression"].replace("w", w)
    exact["problem"]["grid"]["stop"] = 6.28
    path = tmp_path / "exact.json"
    path.write_text(json.dumps(exact))
    for t1, t2 in [(20.0, 20.0), (50.0, 195.0)]:
        in_w = _session_margins(EXAMPLES / "coebra_kuo_digital.json", t1, t2)
        in_z = _session_margins(path, t1, t2)
        report_z = _session_margins(EXAMPLES / "coebra_kuo_z.json", t1, t2)
        for mw, mz, mr in zip(in_w.margins.all(), in_z.margins.all(), report_z.margins.all()):
            assert mz.frequency == pytest.approx(2 * math.atan(mw.frequency) / T, rel=1e-11)
            assert mz.value == pytest.approx(mw.value, rel=1e-11)
            assert mr.frequency == pytest.approx(mz.frequency, rel=0.025)
            if mw.kind == "G":
                assert mr.gain_db == pytest.approx(mw.gain_db, abs=0.3)
            if mw.kind == "P":
                assert mr.phase_deg == pytest.approx(mw.phase_deg, abs=1.5)


def test_the_z_example_runs_and_replays_from_the_cli(tmp_path, capsys):
    path = tmp_path / "kuo_z.json"
    shutil.copy(EXAMPLES / "coebra_kuo_z.json", path)
    assert main(["run", str(path), "--iterations", "40"]) == 0
    assert "converged" in capsys.readouterr().out
    x = load_session(path).records[-1].parameters
    found = _session_margins(path, x["T1"], x["T2"])
    gains, phases = _circle_margins(x["T1"], x["T2"])
    assert min(db for _, db in gains) >= 12 and min(deg for _, deg in phases) >= 50  # the requirements, met
    assert found.margins.phase[0].phase_deg == pytest.approx(phases[0][1], rel=1e-9)
    assert main(["replay", str(path)]) == 0
    assert "reproduce" in capsys.readouterr().out


def _edited(change) -> str:
    data = json.loads((EXAMPLES / "coebra_kuo_z.json").read_text())
    change(data)
    return json.dumps(data)


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda d: d["problem"]["conditions"][0].pop("sample_time"), "needs its sample_time"),
        (lambda d: d["problem"]["grid"].update(stop=7.0), "Nyquist frequency pi/T = 6.28319"),
        (
            lambda d: d["problem"]["conditions"][0]["plant"]["blocks"][1].update(
                transfer={"kind": "delay", "tau": 0.1}
            ),
            "a loop in z takes expressions in z",
        ),
        (
            lambda d: d["problem"]["targets"].append(
                {
                    "measure": "mean_square",
                    "bands": [{"desired": 1.0}],
                    "response": {"input": "r", "output": "y", "psd": "1/(s+1)"},
                }
            ),
            "problem.targets[2].measure: mean_square",
        ),
    ],
)
def test_what_a_z_condition_refuses_is_named(tmp_path, change, words):
    with pytest.raises(SessionError, match=None) as caught:
        parse_session(_edited(change), "kuo_z.json", tmp_path)
    assert words in str(caught.value)


def test_the_step_response_is_the_sampled_loop_s_at_its_samples(tmp_path):
    """The z loop's step response at t = k T against python-control's discrete step (to rounding),
    drawn as a staircase; the horizon from the poles' radii."""
    from engine.closed_loop.step_response import StepSetup, realized, step_response

    session = load_session(EXAMPLES / "coebra_kuo_z.json")
    c = session.problem.conditions[0]
    t1, t2 = 24.0, 146.03
    response = step_response(realized(c.network, {"T1": t1, "T2": t2}), StepSetup())
    samples = np.array(response.y[::2])
    assert response.t[:4] == [0.0, T, T, 2 * T]  # a staircase
    cn, cd = _compensator(t1, t2)
    closed = control.feedback(control.tf(np.polymul(cn, PLANT_NUM), np.polymul(cd, PLANT_DEN), T), 1)
    _, expected = control.step_response(closed, T=np.arange(samples.size) * T)
    np.testing.assert_allclose(samples, expected, atol=1e-12)
    poles = np.abs(np.roots(np.polyadd(np.polymul(cd, PLANT_DEN), np.polymul(cn, PLANT_NUM))))
    slowest = -T / math.log(poles.max())  # s
    assert response.t[-1] == pytest.approx(8 * slowest, abs=T)
    m = response.measures
    assert m.final == pytest.approx(1.0, rel=1e-12)  # a type-1 loop
    assert m.peak == pytest.approx(expected.max(), rel=1e-12) and m.peak_time == pytest.approx(T * expected.argmax())


def test_the_pole_map_and_locus_are_drawn_in_z_with_the_unit_circle(tmp_path):
    from tui.figures.closed_loop import Z_GRID_DAMPINGS, locus_figure, poles_figure
    from tui.state.workbench import Workbench

    path = tmp_path / "kuo_z.json"
    shutil.copy(EXAMPLES / "coebra_kuo_z.json", path)
    view = Workbench(load_session(path)).view()
    fig = poles_figure(view)
    by_label = {s.label: s for s in fig.series if s.label}
    closed = np.array(by_label["closed-loop poles"].x) + 1j * np.array(by_label["closed-loop poles"].y)
    cn, cd = _compensator(20.0, 20.0)
    expected = np.roots(np.polyadd(np.polymul(cd, PLANT_DEN), np.polymul(cn, PLANT_NUM)))
    assert all(np.min(np.abs(expected - p)) < 1e-9 for p in closed)
    assert "|z| = 1" in by_label and "z-plane" in fig.title
    curve = next(s for s in fig.series if s.label.startswith("zeta"))  # the first constant-damping curve
    z = np.array(curve.x) + 1j * np.array(curve.y)
    s = np.log(z[1:-1])  # s T, off z = 1
    np.testing.assert_allclose(-s.real / np.abs(s), Z_GRID_DAMPINGS[0], rtol=1e-12)
    locus = locus_figure(view)
    assert any(s.label == "|z| = 1" for s in locus.series) and "unit-circle crossings" in locus.xlabel


@pytest.mark.parametrize("delay", [0.0, 0.5])
def test_new_discretizes_a_continuous_plant_with_its_hold(tmp_path, capsys, delay):
    """`new --sample-time` with a plant in s: the zero-order-hold equivalent (a whole-sample delay
    as z^-1) and the lead by Tustin's map, against python-control's c2d of the same blocks."""
    path = tmp_path / "held.json"
    plant = "4/(s*(s+2))" + (f"*exp(-{delay}*s)" if delay else "")
    assert main(["new", str(path), "--plant", plant, "--sample-time", str(T), "--compensator", "lead"]) == 0
    session = load_session(path)
    c = session.problem.conditions[0]
    found = analyze(c.network, c.break_at, session.problem.grid.omega, session.problem.condition_values(0))
    held = control.c2d(control.tf([4.0], [1.0, 2.0, 0.0]), T, "zoh") * (control.tf([1], [1, 0], T) if delay else 1)
    lead = control.c2d(control.tf([1.0, 1.0], [0.1, 1.0]), T, "tustin")  # K (1 + T1 s)/(1 + T2 s) at the start
    gm, pm, _, wpc, wgc, _ = control.stability_margins(lead * held)
    assert found.margins.crossover_frequency == pytest.approx(wgc, rel=1e-9)
    assert found.margins.phase[0].phase_deg == pytest.approx(pm, rel=1e-9)
    assert min(m.gain_db for m in found.margins.gain) == pytest.approx(20 * math.log10(gm), rel=1e-9)
    assert found.margins.gain[0].frequency == pytest.approx(wpc, rel=1e-9)


def test_new_keeps_a_plant_typed_in_z(tmp_path):
    path = tmp_path / "typed.json"
    plant = "0.39*(z+1.31)*(z+0.054)/(z*(z-1)*(z-0.368))"
    assert main(["new", str(path), "--plant", plant, "--sample-time", str(T), "--compensator", "lag"]) == 0
    data = json.loads(path.read_text())
    condition = data["problem"]["conditions"][0]
    assert condition["variable"] == "z" and condition["sample_time"] == T
    assert condition["plant"]["blocks"][1]["transfer"] == {"kind": "expression", "expression": plant}
    assert data["problem"]["grid"]["stop"] < math.pi / T
    assert main(["run", str(path), "--iterations", "30"]) == 0


def test_time_targets_on_a_z_condition_read_the_samples(tmp_path):
    """An overshoot target on the Kuo loop in z: slp's row is the overshoot of the response at its
    samples (python-control's discrete step), and the step plot's measures are the same."""
    from engine.closed_loop.step_response import StepSetup, realized, step_response
    from engine.slp.measures import measure_specs, time_value

    data = json.loads((EXAMPLES / "coebra_kuo_z.json").read_text())
    data["problem"]["targets"].append(
        {
            "measure": "overshoot_percent",
            "bands": [{"desired": 25.0}],
            "response": {"input": "r", "output": "y", "horizon": 40.0, "points": 400},
        }
    )
    path = tmp_path / "kuo_overshoot.json"
    path.write_text(json.dumps(data))
    session = load_session(path)
    problem, c = session.problem, session.problem.conditions[0]
    values = {"T1": 24.0, "T2": 146.03}
    ss = realized(c.network, values)
    cn, cd = _compensator(24.0, 146.03)
    closed = control.feedback(control.tf(np.polymul(cn, PLANT_NUM), np.polymul(cd, PLANT_DEN), T), 1)
    _, y = control.step_response(closed, T=np.arange(81) * T)
    expected = 100 * (y.max() - 1.0)
    spec = next(s for s in measure_specs(problem) if s.kind == "overshoot_percent")
    assert time_value(spec, problem, ss, T) == pytest.approx(expected, rel=1e-10)
    assert step_response(ss, StepSetup()).measures.overshoot_percent == pytest.approx(expected, rel=1e-10)


def _ss_session(tmp_path, name: str, sys_d, K: float) -> Path:
    """A unity loop in z: the gain K and a state-space plant given inline in z."""
    data = json.loads((EXAMPLES / "coebra_kuo_z.json").read_text())
    c = data["problem"]["conditions"][0]
    c["sample_time"] = float(sys_d.dt)
    c["plant"]["blocks"] = [
        {"name": "gain", "input": "e", "output": "u", "transfer": {"kind": "expression", "expression": "K"}},
        {
            "name": "plant",
            "input": "u",
            "output": "y",
            "transfer": {
                "kind": "state_space",
                "A": sys_d.A.tolist(),
                "B": sys_d.B[:, 0].tolist(),
                "C": sys_d.C[0].tolist(),
                "D": float(sys_d.D[0, 0]),
            },
        },
    ]
    data["problem"]["parameters"] = [{"name": "K", "value": K}]
    data["problem"]["grid"] = {"start": 1e-3, "stop": 0.999 * math.pi / sys_d.dt, "points": 300}
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(data))
    return path


def test_state_space_blocks_in_z_agree_with_python_control(tmp_path):
    """20 random stable discrete state spaces (orders 1-20, python-control's drss) as blocks of a
    condition in z, kept as state space: the closed-loop poles and the verdict equal python-control's
    on the same dt system; every gain crossover is one on the unit circle (evaluated modally here),
    and none is missed (100 001 points of the circle)."""
    rng = np.random.default_rng(39)
    np.random.seed(39)  # drss draws from numpy's global generator
    for n in range(20):
        order = 1 + n
        sys_d = control.drss(order, 1, 1, strictly_proper=False)
        sys_d.dt = float(rng.choice([1e-3, 0.01, 0.1, 1.0]))
        K = float(10 ** rng.uniform(-1, 1))
        session = load_session(_ss_session(tmp_path, f"ss{n}", sys_d, K))
        c = session.problem.conditions[0]
        found = analyze(c.network, c.break_at, session.problem.grid.omega, {"K": K})
        loop = K * sys_d
        poles = control.poles(control.feedback(loop, 1))
        shown = np.array([p.value for p in found.closed_loop_poles])
        assert found.verdict == ("stable" if np.all(np.abs(poles) < 1) else "unstable"), n
        assert max(np.min(np.abs(shown[:, None] - poles[None, :]), axis=1)) < 1e-7 * max(1, np.abs(poles).max()), n
        circle = _modal(sys_d.A, sys_d.B, sys_d.C, sys_d.D, K)
        w = np.linspace(1e-6, math.pi / sys_d.dt * (1 - 1e-9), 100_001)
        values = circle(np.exp(1j * w * sys_d.dt))
        for m in found.margins.phase:  # |L| = 1 there, on the circle
            assert abs(abs(circle(np.exp(1j * np.array([m.frequency]) * sys_d.dt))[0]) - 1) < 1e-9, n
        crossings = np.flatnonzero(np.diff(np.sign(np.abs(values) - 1)) != 0)
        assert len(found.margins.phase) == crossings.size, n


def _modal(A, B, C, D, K):
    """K (C (zI - A)^-1 B + D) at many z, through A's eigenvectors (vectorized)."""
    lam, V = np.linalg.eig(A)
    left, right = (C @ V)[0], np.linalg.solve(V, B)[:, 0]
    return lambda z: K * ((left * right)[None, :] / (z[:, None] - lam[None, :])).sum(axis=1) + K * D[0, 0]


def test_tune_solves_a_z_loop_below_the_nyquist_frequency(tmp_path):
    """tune's gain for a phase margin is searched up to pi/T, not beyond (where tan wraps and a
    phase crossing of an alias gave K = 4e-15); the tuned loop's margin, checked on the unit circle."""
    path = tmp_path / "tuned.json"
    plant = "0.39*(z+1.31)*(z+0.054)/(z*(z-1)*(z-0.368))"
    assert main(["new", str(path), "--plant", plant, "--sample-time", str(T), "--compensator", "lead"]) == 0
    assert main(["tune", str(path), "--gain-for", "pm=50"]) == 0
    session = load_session(path)
    c = session.problem.conditions[0]
    found = analyze(c.network, c.break_at, session.problem.grid.omega, session.problem.condition_values(0))
    assert found.margins.phase[0].phase_deg == pytest.approx(50.0, abs=1e-9)
    assert found.margins.crossover_frequency < math.pi / T


@pytest.mark.parametrize(
    "plant, words",
    [
        ("z^2/(z-0.5)", "not causal"),  # proper in w, which no computer can run
    ],
)
def test_a_block_in_z_that_leads_its_input_is_refused(tmp_path, plant, words):
    data = json.loads((EXAMPLES / "coebra_kuo_z.json").read_text())
    data["problem"]["conditions"][0]["plant"]["blocks"][1]["transfer"]["expression"] = plant
    with pytest.raises(SessionError) as caught:
        parse_session(json.dumps(data), "kuo_z.json", tmp_path)
    assert words in str(caught.value) and "problem.conditions[0]" in str(caught.value)


def test_a_held_delay_of_more_samples_than_a_block_may_have_is_refused(tmp_path, capsys):
    path = tmp_path / "held.json"
    plant = "exp(-0.3*s)/(s+1)"
    assert main(["new", str(path), "--plant", plant, "--sample-time", "1e-300", "--compensator", "pi"]) == 2
    assert "3e+299 samples" in capsys.readouterr().err and not path.exists()

"""`loopcraft set`, `loopcraft tune` and `loopcraft analyze FILE.json` (issue 38, section
4): the lead for 1/(s^2 (s+10)) designed in three commands, checked against
python-control on the saved session's values; bad input refused with exit status 2 and
the file left as it was."""

from __future__ import annotations

import json

import control as ct
import numpy as np
import pytest

from tui.cli import main


def _run(capsys, *args) -> tuple[int, str, str]:
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def _loop(path) -> ct.TransferFunction:
    """The saved design's loop, built by python-control from the template's structure."""
    values = {p["name"]: p["value"] for p in json.loads(path.read_text())["problem"]["parameters"]}
    lead = ct.tf([values["K"] * values["T1"], values["K"]], [values["T2"], 1])
    return lead * ct.tf([1], [1, 10, 0, 0])


@pytest.fixture
def lead(tmp_path, capsys):
    path = tmp_path / "lead.json"
    assert _run(capsys, "new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead")[0] == 0
    text = json.loads(path.read_text())["problem"]["conditions"][0]["plant"]["blocks"][0]["transfer"]["expression"]
    assert text == "K*(1+T1*s)/(1+T2*s)"  # the structure `_loop` rebuilds
    return path


def test_a_lead_for_a_double_integrator_in_three_commands(lead, capsys):
    code, out, _ = _run(capsys, "tune", str(lead), "--gain-for", "crossover=1")
    assert code == 0 and "exact on the loop" in out
    assert abs(_loop(lead)(1j)) == pytest.approx(1.0, rel=1e-10)
    assert _run(capsys, "set", str(lead), "T1*=1.5")[0] == 0
    code, out, _ = _run(capsys, "tune", str(lead), "--gain-for", "pm=45")
    gm, pm, _, _, wc, _ = ct.stability_margins(_loop(lead))
    assert code == 0 and pm == pytest.approx(45.0, abs=1e-6) and wc >= 1.0
    code, out, _ = _run(capsys, "analyze", str(lead))
    assert code == 0 and f"{wc:.6g}" in out and "45.0000 deg" in out and "closed loop: stable" in out
    assert "compensator compensator:" in out and "zero at 0.666667 rad/s (T 1.5 s) [T1]" in out
    code, out, _ = _run(capsys, "analyze", str(lead), "--json")
    parts = json.loads(out)["compensators"]["compensator"]
    assert code == 0 and [p["kind"] for p in parts] == ["gain", "zero", "pole"] and parts[2]["frequency"] == 10.0


def test_set_scales_by_a_factor_and_by_decibels(lead, capsys):
    before = {p["name"]: p["value"] for p in json.loads(lead.read_text())["problem"]["parameters"]}
    code, out, _ = _run(capsys, "set", str(lead), "K*=+6dB", "T2=0.05")
    after = {p["name"]: p["value"] for p in json.loads(lead.read_text())["problem"]["parameters"]}
    assert code == 0 and after["K"] == pytest.approx(before["K"] * 10 ** (6 / 20)) and after["T2"] == 0.05
    assert f"K: {before['K']:.6g} -> {after['K']:.6g}" in out


@pytest.mark.parametrize(
    "args,message",
    [
        (["set", "{f}", "T9=1"], "T9: no such parameter; the session has K, T1, T2"),
        (["set", "{f}", "T1=1e9"], "is above its bound"),
        (["set", "{f}", "T1=3dB"], "dB scales a value"),
        (["set", "{f}", "T1"], "write NAME=VALUE"),
        (["tune", "{f}", "--gain-for", "bandwidth=3"], "write crossover=W (rad/s) or pm=DEG"),
        (["tune", "{f}", "--gain-for", "pm=95", "--parameter", "T1"], "not proportional"),
        (["tune", "{f}", "--gain-for", "pm=170"], "never reaches"),
        (["analyze", "{f}", "--condition", "cruise"], "the session's conditions are nominal"),
    ],
)
def test_bad_input_is_refused_and_the_file_is_untouched(lead, capsys, args, message):
    saved = lead.read_bytes()
    code, _, err = _run(capsys, *[a.format(f=lead) for a in args])
    assert code == 2 and message in err and "Traceback" not in err
    assert lead.read_bytes() == saved


def test_tune_without_a_gain_names_what_to_do(capsys, tmp_path):
    import shutil
    from pathlib import Path

    example = Path(__file__).resolve().parents[1] / "sessions" / "examples" / "report003_lag_lead.json"
    path = tmp_path / example.name
    shutil.copy2(example, path)
    code, _, err = _run(capsys, "tune", str(path), "--gain-for", "crossover=3")
    assert code == 2 and "no parameter scales the loop of nominal" in err


def test_tune_sets_a_pure_gain_compensator(capsys, tmp_path):
    """The gain template (K alone): the crossover put where it is asked."""
    path = tmp_path / "two.json"
    assert _run(capsys, "new", str(path), "--plant", "1/(s*(s+1))", "--compensator", "gain")[0] == 0
    data = json.loads(path.read_text())
    names = [p["name"] for p in data["problem"]["parameters"]]
    assert names == ["K"]
    code, _, _ = _run(capsys, "tune", str(path), "--gain-for", "crossover=2")
    k = json.loads(path.read_text())["problem"]["parameters"][0]["value"]
    assert code == 0 and np.isfinite(k) and abs(k * ct.tf([1], [1, 1, 0])(2j)) == pytest.approx(1.0, rel=1e-10)


def test_set_moves_a_compensator_item_by_its_own_parameter(lead, capsys):
    code, out, _ = _run(capsys, "analyze", str(lead))
    assert "compensator.zero1: zero at 1 rad/s (T 1 s) [T1]" in out and "compensator.pole1: pole at" in out
    code, out, err = _run(
        capsys, "set", str(lead), "compensator.zero1=0.8", "compensator.pole1*=1.5", "compensator.gain*=+6dB"
    )
    values = {p["name"]: p["value"] for p in json.loads(lead.read_text())["problem"]["parameters"]}
    assert code == 0 and "compensator.zero1: 1 -> 0.8 (T1: 1 -> 1.25)" in out, err
    assert np.min(np.abs(_loop(lead).zeros() + 0.8)) < 1e-9  # python-control: the zero at -0.8, the pole at -15
    assert np.min(np.abs(_loop(lead).poles() + 15.0)) < 1e-8
    assert values["K"] == pytest.approx(10 ** (6 / 20), rel=1e-10)


@pytest.mark.parametrize(
    "item,message",
    [
        ("compensator.pair1=3", "compensator has gain, zero1, pole1"),
        ("plant.pole1=3", "no compensator block 'plant'"),
        ("compensator.zero1=1e-9", "within its bounds"),
    ],
)
def test_an_item_that_cannot_move_says_why(lead, capsys, item, message):
    saved = lead.read_bytes()
    code, _, err = _run(capsys, "set", str(lead), item)
    assert code == 2 and message in err and lead.read_bytes() == saved


def test_a_root_of_a_cip_polynomial_moves_by_its_coefficients_with_the_dc_gain_kept(tmp_path, capsys):
    """cip's blocks are (x0 + x1 s + x2 s^2)/(y0 + y1 s + y2 s^2), labelled vehicle.1 ..:
    moving zero1 sets x1 and x2 so that the numerator is x0 (1 + s/z1')(1 + s/z2)."""
    import shutil
    from pathlib import Path

    for name in ("cip_launch_vehicle.json", "cip_launch_vehicle.csv"):
        shutil.copy(Path(__file__).resolve().parents[1] / "sessions" / "examples" / name, tmp_path / name)
    path = tmp_path / "cip_launch_vehicle.json"
    before = {p["name"]: p["value"] for p in json.loads(path.read_text())["problem"]["parameters"]}
    z1, z2 = sorted(abs(np.roots([before[f"vehicle_1_x{k}"] for k in (2, 1, 0)])))
    code, out, err = _run(capsys, "set", str(path), "vehicle.1.zero1*=1.2")
    after = {p["name"]: p["value"] for p in json.loads(path.read_text())["problem"]["parameters"]}
    x0, moved = before["vehicle_1_x0"], 1.2 * z1
    assert code == 0, err
    assert after["vehicle_1_x0"] == x0 and after["vehicle_1_x1"] == pytest.approx(x0 * (1 / moved + 1 / z2), rel=1e-9)
    assert after["vehicle_1_x2"] == pytest.approx(x0 / (moved * z2), rel=1e-9)
    assert all(after[k] == before[k] for k in before if not k.startswith("vehicle_1_x"))


def test_a_run_then_a_hand_move_then_a_run_replays_every_iteration(lead, capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    assert _run(capsys, "run", str(lead), "--iterations", "3")[0] == 0
    assert _run(capsys, "tune", str(lead), "--gain-for", "crossover=1")[0] == 0
    assert _run(capsys, "run", str(lead), "--iterations", "2")[0] == 0
    stages = json.loads(lead.read_text())["earlier"]
    assert [s["kind"] for s in stages] == ["run", "hand"] and [c["name"] for c in stages[1]["changes"]] == ["K"]
    code, out, _ = _run(capsys, "replay", str(lead))
    assert code == 0 and "iterations of 1 earlier run(s), with 1 hand move(s) between" in out
    data = json.loads(lead.read_text())
    data["earlier"][0]["records"][1]["parameters"]["T1"] *= 1.01  # an earlier run's record that does not reproduce
    lead.write_text(json.dumps(data))
    code, out, err = _run(capsys, "replay", str(lead))
    assert code != 0 and "earlier stage 1 (a " in out + err and "iteration 2 diverges" in out + err


def test_a_damping_is_a_pairs_alone(lead, capsys):
    before = lead.read_text()
    code, _, err = _run(capsys, "set", str(lead), "compensator.gain.zeta=0.5")
    assert code == 2 and "the gain has no damping" in err and lead.read_text() == before


@pytest.mark.parametrize("order", [["T1=3", "T2=0.3"], ["T2=0.3", "T1=3"]])
def test_set_checks_its_assignments_as_one_change(lead, capsys, order):
    """Issue 51, section 4: the template holds T1 <= 20*T2 (T1 = 1, T2 = 0.1 at the start);
    T1 = 3 alone breaks it, T1 = 3 with T2 = 0.3 does not: either order is the same change."""
    code, out, err = _run(capsys, "set", str(lead), *order)
    values = {p["name"]: p["value"] for p in json.loads(lead.read_text())["problem"]["parameters"]}
    assert code == 0, err
    assert values["T1"] == 3.0 and values["T2"] == 0.3


@pytest.mark.parametrize(
    "args, message",
    [
        (["T1=30", "T2=0.3"], "T1=30, T2=0.3: constraints[0] 'T1 <= 20*T2' is not met after the change"),
        (["T2=0.3", "T1=30"], "T2=0.3, T1=30: constraints[0] 'T1 <= 20*T2' is not met after the change"),
        (["T2=2", "T1=0.05"], "T2=2, T1=0.05: constraints[1] 'T2 <= 20*T1' is not met after the change"),
        (["T2=0.3", "T1=1e9"], "T1=1e+09: T1 = 1e+09 is above its bound 10000 (max): not set"),
    ],
)
def test_a_change_that_breaks_a_constraint_names_it_and_changes_nothing(lead, capsys, args, message):
    saved = lead.read_bytes()
    code, _, err = _run(capsys, "set", str(lead), *args)
    assert code == 2 and message in err and "Traceback" not in err
    assert lead.read_bytes() == saved


def _two_solutions(lead, capsys, crossover_target: bool = False):
    """The lead with its zero at 0.535 rad/s: two gains give PM 47 deg (crossovers 0.80 and 2.9 rad/s)."""
    assert _run(capsys, "set", str(lead), "T1=1.87")[0] == 0
    if crossover_target:  # crossover >= 1 rad/s, met at K = 1... 7.14 (the tutorial's requirement)
        data = json.loads(lead.read_text())
        data["problem"]["targets"].append({"measure": "crossover_frequency", "bands": [{"desired": 1.0}]})
        lead.write_text(json.dumps(data))
        assert _run(capsys, "tune", str(lead), "--gain-for", "crossover=1.5")[0] == 0


def test_tune_for_a_phase_margin_lists_every_solution_by_frequency(lead, capsys):
    """Issue 54: every gain that gives the margin, ordered by crossover, the one taken marked;
    --pick N takes the Nth; --json lists them; each checked with python-control."""
    _two_solutions(lead, capsys)
    before = lead.read_text()
    code, out, _ = _run(capsys, "tune", str(lead), "--gain-for", "pm=47", "--out", str(lead.with_name("a.json")))
    assert code == 0 and "2 gains give pm=47 deg" in out
    first, second = [line for line in out.splitlines() if line[2:4] in ("1.", "2.")]
    assert first.startswith("* 1. crossover 0.79") and second.startswith("  2. crossover 2.9")
    _, pm, _, _, wc, _ = ct.stability_margins(_loop(lead.with_name("a.json")))
    assert pm == pytest.approx(47, abs=1e-6) and wc == pytest.approx(0.7958, rel=1e-3)
    lead.write_text(before)
    code, out, _ = _run(capsys, "tune", str(lead), "--gain-for", "pm=47", "--pick", "2", "--json")
    data = json.loads(out)
    assert code == 0 and data["picked"] == 2 and [c["pick"] for c in data["choices"]] == [1, 2]
    assert data["choices"][0]["frequency"] < data["choices"][1]["frequency"] == data["frequency"]
    _, pm, _, _, wc, _ = ct.stability_margins(_loop(lead))
    assert pm == pytest.approx(47, abs=1e-6) and wc == pytest.approx(data["frequency"], rel=1e-8)
    code, _, err = _run(capsys, "tune", str(lead), "--gain-for", "pm=47", "--pick", "3")
    assert code == 2 and "--pick 3: pm=47 has 2 solution(s), 1..2" in err


def test_tune_for_a_phase_margin_keeps_a_met_requirement_met_by_default(lead, capsys):
    """The lowest crossover would break crossover >= 1 rad/s: the default is the next one."""
    _two_solutions(lead, capsys, crossover_target=True)
    code, out, _ = _run(capsys, "tune", str(lead), "--gain-for", "pm=47", "--json")
    data = json.loads(out)
    assert code == 0 and data["choices"][0]["breaks"] == ["WC1"] and data["choices"][1]["breaks"] == []
    assert data["picked"] == 2 and data["frequency"] > 1

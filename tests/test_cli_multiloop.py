"""`loopcraft analyze --ss FILE` of a square plant of several inputs (issue 56): every loop
at a time and the multi-loop disk margin, the JSON keys other programs read, and the
refusals (a non-square plant, an unknown break, options a multi-loop plant does not take)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.engine.test_multiloop import satellite
from tui.cli import main


def _run(capsys, *args) -> tuple[int, str, str]:
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def satellite_file(tmp_path):
    a, b, c, d = satellite()
    path = tmp_path / "satellite.npz"
    np.savez(path, A=a, B=b, C=c, D=d)
    return str(path)


def test_the_satellite_reports_both_loops_and_the_multi_loop_margin(capsys, satellite_file):
    code, out, err = _run(capsys, "analyze", "--ss", satellite_file, "--json")
    assert code == 0, err
    data = json.loads(out)
    assert [loop["name"] for loop in data["loops"]] == ["u1", "u2"]
    for loop in data["loops"]:
        assert loop["gain_margins"] == [] and loop["closed_loop_stable"] is True
        (pm,) = loop["phase_margins"]
        assert pm["phase_deg"] == pytest.approx(90.0, rel=1e-12) and pm["frequency"] == pytest.approx(1.0, rel=1e-12)
        assert loop["disk_margin"]["alpha"] == pytest.approx(2.0, rel=1e-9)
    together = data["multi_loop_disk_margin"]
    for key in ("alpha", "alpha_lower", "alpha_upper", "frequency", "gain_margin_db", "phase_margin_deg", "method"):
        assert key in together
    assert together["alpha_lower"] <= together["alpha"] <= together["alpha_upper"]
    assert (together["alpha_upper"] - together["alpha_lower"]) / together["alpha_upper"] <= 1e-6
    assert round(together["alpha"], 5) == 0.09975 and round(together["frequency"], 2) == 0.05
    assert together["gain_margin_db"] == pytest.approx(0.87, abs=0.005)
    assert together["phase_margin_deg"] == pytest.approx(5.71, abs=0.005)


def test_one_break_is_reported_alone(capsys, satellite_file):
    code, out, err = _run(capsys, "analyze", "--ss", satellite_file, "--break", "u2", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert [loop["name"] for loop in data["loops"]] == ["u2"] and data["multi_loop_disk_margin"] is None


def test_the_text_names_every_loop_and_the_bracket(capsys, satellite_file):
    code, out, _ = _run(capsys, "analyze", "--ss", satellite_file)
    assert code == 0
    assert "loop broken at u1" in out and "loop broken at u2" in out
    assert "multi-loop disk margin (skew 0, every break at once): alpha 0.0997512" in out and "certified" in out


@pytest.mark.parametrize(
    ("extra", "says"),
    [
        (["--break", "u3"], "--break 'u3': the plant's breaks are u1, u2"),
        (["--tf", "2"], "takes no --tf"),
        (["--delay", "0.1"], "takes no --delay"),
    ],
)
def test_what_a_multi_loop_plant_refuses_is_said(capsys, satellite_file, extra, says):
    code, out, err = _run(capsys, "analyze", "--ss", satellite_file, *extra)
    assert code == 2 and out == "" and says in err and "Traceback" not in err


def test_a_non_square_plant_is_refused(capsys, tmp_path):
    path = tmp_path / "wide.npz"
    np.savez(path, A=-np.eye(3), B=np.ones((3, 2)), C=np.ones((3, 3)))
    code, _, err = _run(capsys, "analyze", "--ss", str(path))
    assert code == 2 and "2 inputs and 3 outputs" in err and "wide.npz" in err


def test_a_break_of_a_typed_loop_is_refused(capsys):
    code, _, err = _run(capsys, "analyze", "--tf", "1/s", "--break", "u1")
    assert code == 2 and "--break u1" in err


def test_a_session_loop_broken_at_another_signal_of_one_loop_has_the_same_margins(capsys):
    """One loop broken anywhere along it: the same loop gain turned round, so the same margins."""
    from tests.test_layout import ROOT

    session = str(ROOT / "sessions" / "examples" / "cip_launch_vehicle.json")
    _, at_e, _ = _run(capsys, "analyze", session, "--json")
    code, at_u, err = _run(capsys, "analyze", session, "--break", "vehicle.u", "--json")
    assert code == 0, err
    a, b = json.loads(at_e)["phase_margins"], json.loads(at_u)["phase_margins"]
    assert len(a) == len(b) > 0
    for x, y in zip(a, b):
        assert x["frequency"] == pytest.approx(y["frequency"], rel=1e-9)
        assert x["phase_deg"] == pytest.approx(y["phase_deg"], rel=1e-9)
    code, _, err = _run(capsys, "analyze", session, "--break", "nope")
    assert code == 2 and "--break 'nope'" in err and "vehicle.u" in err


def test_a_plant_in_z_reports_rad_s_and_needs_its_sample_time(capsys, tmp_path):
    from scipy.signal import cont2discrete

    a, b, c, d, _ = cont2discrete(satellite(), 0.01, method="zoh")
    path = tmp_path / "in_z.npz"
    np.savez(path, A=a, B=b, C=c, D=d)
    code, out, err = _run(capsys, "analyze", "--ss", str(path), "--variable", "z", "--sample-time", "0.01", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["variable"] == "z" and data["sample_time"] == 0.01
    assert all(loop["sample_time"] == 0.01 for loop in data["loops"])
    together = data["multi_loop_disk_margin"]
    assert together["certified"] and 0 < together["frequency"] < np.pi / 0.01
    code, _, err = _run(capsys, "analyze", "--ss", str(path), "--variable", "z")
    assert code == 2 and "--sample-time" in err


def test_the_simultaneous_margins_are_asked_for(capsys, satellite_file):
    code, out, err = _run(capsys, "analyze", "--ss", satellite_file, "--simultaneous", "--json")
    assert code == 0, err
    found = json.loads(out)["simultaneous_margins"]
    assert found["gain"]["unit"] == "dB" and found["gain"]["lower"] <= found["gain"]["upper"]
    assert found["phase"]["status"] == "tight"
    _, out, _ = _run(capsys, "analyze", "--ss", satellite_file, "--json")
    assert json.loads(out)["simultaneous_margins"] is None
    code, _, err = _run(capsys, "analyze", "--ss", satellite_file, "--simultaneous", "--break", "u1")
    assert code == 2 and "--simultaneous" in err
    code, _, err = _run(capsys, "analyze", "--tf", "1/s", "--simultaneous")
    assert code == 2 and "--simultaneous" in err


def test_a_session_condition_lists_its_breaks_and_analyze_reports_each(capsys, tmp_path):
    """`breaks` in the session format (absent: [break_at]): analyze FILE.json reports every one as
    `loops`; each is the loop broken at that signal (one loop here: the same margins everywhere)."""
    from tests.test_layout import ROOT

    examples = ROOT / "sessions" / "examples"
    data = json.loads((examples / "cip_launch_vehicle.json").read_text())
    (tmp_path / "cip_launch_vehicle.csv").write_bytes((examples / "cip_launch_vehicle.csv").read_bytes())
    data["problem"]["conditions"][0]["breaks"] = ["e", "vehicle.u"]
    path = tmp_path / "breaks.json"
    path.write_text(json.dumps(data))
    code, out, err = _run(capsys, "analyze", str(path), "--json")
    assert code == 0, err
    found = json.loads(out)
    assert [loop["name"] for loop in found["loops"]] == ["e", "vehicle.u"]
    assert found["multi_loop_disk_margin"] is None and "no multi-loop disk margin" in err  # a table: no realization
    for loop in found["loops"]:
        assert loop["phase_margins"][0]["frequency"] == pytest.approx(found["phase_margins"][0]["frequency"], rel=1e-9)
    data["problem"]["conditions"][0]["breaks"] = ["e", "nowhere"]
    path.write_text(json.dumps(data))
    code, _, err = _run(capsys, "analyze", str(path))
    assert code == 2 and "nowhere" in err


def test_a_break_that_opens_no_loop_and_an_unstable_loop_are_said(capsys, tmp_path):
    path = tmp_path / "open.npz"
    np.savez(path, A=-np.eye(2), B=[[1.0, 0.0], [0.0, 0.0]], C=np.eye(2))
    code, out, err = _run(capsys, "analyze", "--ss", str(path))
    assert code == 2 and out == "" and "u2: the loop seen there is 0 at every frequency" in err
    path = tmp_path / "unstable.npz"
    np.savez(path, A=-np.eye(2), B=np.eye(2), C=-2.0 * np.eye(2))  # P = -2/(s+1) I
    code, out, err = _run(capsys, "analyze", "--ss", str(path), "--json")
    assert code == 0, err
    together = json.loads(out)["multi_loop_disk_margin"]
    assert together["alpha"] == 0 and together["status"] == "unstable" and "not stable" in together["notes"][0]
    assert all(loop["verdict"] == "unstable" for loop in json.loads(out)["loops"])

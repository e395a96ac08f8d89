"""`loopcraft export --to matlab|json|csv`, and the exports of tabulated plants.

Numbers are checked against python-control built independently from the
examples' own formulas (numpy.polymul of the factors), never against the
export's own arithmetic."""

from __future__ import annotations

import csv
import io
import json
import re
import runpy
import subprocess
import sys
from pathlib import Path

import control
import numpy as np
import pytest

from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
LAG_LEAD = EXAMPLES / "coebra_lag_lead.json"  # (1+10s)(1+0.2s)/((1+10s)(1+0.2s)) x 16000/(s(s+8)(s+20))
PLANT = control.tf([16000.0], np.polymul([1.0, 0.0], np.polymul([1.0, 8.0], [1.0, 20.0])))


def _export(capsys, path: Path, to: str, *extra: str) -> str:
    assert main(["export", str(path), "--to", to, *extra]) == 0
    return capsys.readouterr().out


def test_matlab_script_has_every_block_and_full_precision_numbers(capsys):
    text = _export(capsys, EXAMPLES / "coebra_launch_vehicle.json", "matlab")
    session = json.loads((EXAMPLES / "coebra_launch_vehicle.json").read_text())
    for condition in session["problem"]["conditions"]:
        assert f"%% condition '{condition['name']}'" in text
        for block in condition["plant"]["blocks"]:
            assert f"% {block['name']} (" in text
        for junction in condition["plant"]["junctions"]:
            assert f"% {junction['name']}" in text
    for p in session["problem"]["parameters"]:
        values = p["value"] if isinstance(p["value"], list) else [p["value"]]
        assert (
            f"%   {p['name']} = "
            + (
                " ".join(repr(float(v)) for v in values)
                if len(values) == 1
                else "[" + " ".join(repr(float(v)) for v in values) + "] (one value per condition)"
            )
            in text
        )
    # three conditions, each the loop at its four breaks (dc, u_att, u_rate, u_acc), the others closed
    assert text.count("= -connect(") == 12 and text.count("allmargin(") == 12
    assert "L_switch_out_at_u_att = -connect(" in text
    assert "tf([-1600.0], [1.0 56.0 1600.0], 'InputName', 'dc', 'OutputName', 'delta')" not in text  # broken at dc
    assert "tf([-1600.0], [1.0 56.0 1600.0], 'InputName', 'dc_loop', 'OutputName', 'delta')" in text
    assert "sumblk('dc_loop = dc')" in text


def test_matlab_numbers_read_back_exactly(capsys):
    """Coefficients as repr writes them: the shortest text that reads back the same double."""
    text = _export(capsys, EXAMPLES / "report003_lag_lead.json", "matlab")
    assert "tf([16000.0], [1.0 28.0 160.0 0.0]" in text
    assert "%   z1 = 1.0\n" in text and "%   p2 = 50.0\n" in text


def test_json_compensators_and_state_spaces(capsys):
    data = json.loads(_export(capsys, LAG_LEAD, "json"))
    (condition,) = data["conditions"]
    (comp,) = condition["compensators"]
    num = np.polymul([10.0, 1.0], [0.2, 1.0])
    assert comp["numerator"] == pytest.approx(list(num), rel=1e-15)
    assert comp["denominator"] == pytest.approx(list(num), rel=1e-15)
    assert comp["zeros"] == [] and comp["poles"] == []  # equal roots cancel (T1 = T3, T2 = T4 at the start)
    loop = condition["open_loop"]
    ss = control.ss(loop["A"], loop["B"], loop["C"], loop["D"])
    compensator = control.tf(num, num)
    w = np.array([0.3, 3.0, 12.649, 30.0])
    expected = (compensator * PLANT)(1j * w)
    assert np.all(np.abs(ss(1j * w) - expected) <= 1e-10 * np.abs(expected))
    closed = condition["closed_loop"]
    poles = np.sort_complex(np.linalg.eigvals(np.array(closed["A"])))
    reference = np.sort_complex(control.poles(control.feedback(compensator * PLANT, 1)))
    assert np.abs(poles[np.abs(poles) > 1e-6] - reference[np.abs(reference) > 1e-6]).max() <= 1e-6 * 30
    assert closed["inputs"] == ["r"] and set(closed["outputs"]) == {"r", "u", "y", "e"}


def test_json_zeros_poles_and_gain(capsys):
    data = json.loads(_export(capsys, EXAMPLES / "report003_lag_lead.json", "json"))
    comp, plant = data["conditions"][0]["entries"][:2]
    assert comp["compensator"] and not plant["compensator"]
    assert sorted(z[0] for z in comp["zeros"]) == pytest.approx([-5.0, -1.0], rel=1e-14)
    assert sorted(p[0] for p in comp["poles"]) == pytest.approx([-50.0, -0.1], rel=1e-14)
    assert comp["gain"] == 1.0 and plant["gain"] == 16000.0
    assert sorted(p[0] for p in plant["poles"]) == pytest.approx([-20.0, -8.0, 0.0], abs=1e-14)


def test_json_w_plane_gives_the_z_domain_form(capsys):
    """Kuo's digital compensator (1 + 20 w)/(1 + 20 w): in z by w = (z - 1)/(z + 1),
    checked by evaluating both at z = exp(j 0.4), w = (z - 1)/(z + 1)."""
    data = json.loads(_export(capsys, EXAMPLES / "coebra_kuo_digital.json", "json", "--sample-time", "0.5"))
    (comp,) = data["conditions"][0]["compensators"]
    z_form = comp["z_domain"]
    assert z_form["sample_time"] == 0.5
    z = np.exp(0.4j)
    w = (z - 1) / (z + 1)
    hz = np.polyval(z_form["numerator"], z) / np.polyval(z_form["denominator"], z)
    hw = np.polyval(comp["numerator"], w) / np.polyval(comp["denominator"], w)
    assert hz == pytest.approx(hw, rel=1e-12)
    assert data["conditions"][0]["variable"] == "w"


def test_csv_is_the_loop_on_the_session_s_grid(capsys):
    text = _export(capsys, EXAMPLES / "report003_lag_lead.json", "csv")
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(rows) == 300 and rows[0]["condition"] == "nominal"
    loop = control.tf(np.polymul([1.0, 1.0], [1.0, 5.0]), np.polymul([1.0, 0.1], [1.0, 50.0])) * PLANT
    for row in rows[::37]:
        w = float(row["frequency_rad_per_s"])
        expected = loop(1j * w)
        assert complex(float(row["open_real"]), float(row["open_imag"])) == pytest.approx(expected, rel=1e-12)
        assert float(row["open_mag_db"]) == pytest.approx(20 * np.log10(abs(expected)), rel=1e-12)
        t = expected / (1 + expected)
        assert complex(float(row["closed_real"]), float(row["closed_imag"])) == pytest.approx(t, rel=1e-12)
    assert float(rows[0]["frequency_rad_per_s"]) == pytest.approx(0.01)


def test_tabulated_plants_export_their_tables_which_a_peer_reads_back_exactly(capsys, tmp_path):
    """cip_launch_vehicle's table becomes a control.frd of the table itself: the script
    runs with no warning and no spurious margin at 0 rad/s, and its loop's response at the
    table's frequencies is loopcraft's own to 1e-12; MATLAB gets an frd and JSON the
    table (issue 40, section 2)."""
    from engine.loop.responses import open_loop
    from sessions.store import load_session

    text = _export(capsys, EXAMPLES / "cip_launch_vehicle.json", "python")
    assert "control.frd(" in text and "zpk(" not in text and "the table itself (999 frequencies)" in text
    script = tmp_path / "vehicle.py"
    script.write_text(text)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "Warning" not in done.stderr, done.stderr
    assert " at 0 " not in done.stdout and "loopcraft (fitted (residual" in done.stdout
    ns = runpy.run_path(str(script))
    loop = ns["CONDITIONS"]["flight"][0]()
    session = load_session(EXAMPLES / "cip_launch_vehicle.json")
    c = session.problem.conditions[0]
    ours = open_loop(c.network, c.break_at, loop.omega, session.problem.condition_values(0), sensitivities=False).value
    assert np.allclose(np.squeeze(loop.frdata), ours, rtol=1e-12, atol=0)
    matlab = _export(capsys, EXAMPLES / "cip_launch_vehicle.json", "matlab")
    assert "frd([" in matlab and "the table itself (999 frequencies, rad/s)" in matlab
    data = json.loads(_export(capsys, EXAMPLES / "seidel_inlet_pi.json", "json"))
    tables = [e for e in data["conditions"][0]["entries"] if e["kind"] == "table"]
    assert {e["block"] for e in tables} == {"G1", "G2", "Ga"} and all(len(e["frequencies"]) > 10 for e in tables)


def test_a_fit_is_a_labelled_option_with_its_residual_or_refused_with_the_reason(capsys):
    text = _export(capsys, EXAMPLES / "cip_launch_vehicle.json", "matlab", "--fit")
    residuals = [float(r) for r in re.findall(r"AAA fit of table\(.*?\), degree \d+, residual ([0-9.e+-]+)", text)]
    assert len(residuals) == 1 and all(0 < r < 1e-3 for r in residuals) and "zpk([" in text
    assert main(["export", str(EXAMPLES / "seidel_inlet_pi.json"), "--to", "python", "--fit"]) == 2
    assert "misses the table by" in capsys.readouterr().err  # a fit that does not stand for the table


def test_an_improper_block_is_refused_by_name_by_the_python_and_matlab_exports(capsys, tmp_path):
    """python-control's interconnect cannot realize an improper block (main wrote a script that raised
    'transfer function is non-proper'); GNU Octave's connect joins it as a descriptor system, wrongly on
    cip_dual_channel --fit (|L| 666 at loopcraft's crossover, where it is 1): main wrote that MATLAB script
    (exit 0).  Both exports refuse it in one line naming the block; MATLAB's in a unity loop too (a
    proportional-derivative typed by hand).  The tables themselves are exported: Octave assembles that loop
    from each block's response (exact for an improper one: test_octave_exports)."""
    dual = EXAMPLES / "cip_dual_channel.json"
    for to in ("python", "matlab"):
        assert main(["export", str(dual), "--to", to, "--fit"]) == 2
        err = capsys.readouterr().err
        assert (
            err.count("\n") == 1 and "block 'attitude.1' is improper (numerator degree 2 > denominator degree 1)" in err
        )
    pd = tmp_path / "pd.json"
    assert main(["new", str(pd), "--plant", "1/(s*(s+1)*(s+5))", "--compensator", "K*(1+Td*s)"]) == 0
    capsys.readouterr()
    assert main(["export", str(pd), "--to", "matlab"]) == 2
    err = capsys.readouterr().err
    assert "block 'compensator' is improper (numerator degree 1 > denominator degree 0)" in err and "far pole" in err
    assert "frd(" in _export(capsys, dual, "matlab")


def test_a_state_space_block_is_exported_as_its_matrices(capsys, tmp_path):
    """A session whose plant is a state space (`new --plant-file`): python-control and MATLAB
    get ss(A, B, C, D), JSON its matrices, CSV its response; before, every format refused it
    ("it is a StateSpaceTransfer entry").  Against python-control's ss of the matrices written."""
    rng = np.random.default_rng(4)
    A = np.diag(-np.exp(rng.uniform(-1, 2, 5))) + np.triu(rng.standard_normal((5, 5)), 1)
    B, C = rng.standard_normal((5, 1)), rng.standard_normal((1, 5))
    np.savez(tmp_path / "plant.npz", A=A, B=B, C=C, D=np.zeros((1, 1)))
    session = tmp_path / "s.json"
    assert main(["new", "--plant-file", str(tmp_path / "plant.npz"), "--compensator", "gain", str(session)]) == 0
    capsys.readouterr()
    plant = control.ss(A, B, C, 0.0)
    script = tmp_path / "exported.py"
    script.write_text(_export(capsys, session, "python"))
    loop = next(iter(runpy.run_path(str(script))["CONDITIONS"].values()))[0]()
    w = np.array([0.1, 1.0, 7.0])
    gain = loop(1j * w) / plant(1j * w)  # the compensator: a constant gain
    assert np.allclose(gain, gain[0], rtol=1e-12) and "control.ss(" in script.read_text()
    assert re.search(
        r"= ss\(\[[-0-9.e ;]+\], \[[-0-9.e ]+\]\.', \[[-0-9.e ]+\], 0\.0", _export(capsys, session, "matlab")
    )
    (entry,) = [
        e
        for e in json.loads(_export(capsys, session, "json"))["conditions"][0]["entries"]
        if e["kind"] == "state_space"
    ]
    assert np.array_equal(entry["A"], A) and np.array_equal(entry["B"], B[:, 0]) and np.array_equal(entry["C"], C[0])
    rows = np.array([r[1:] for r in csv.reader(io.StringIO(_export(capsys, session, "csv")))][1:], dtype=float)
    gh = rows[:, 3] + 1j * rows[:, 4]  # frequency, then GH's dB, phase, real and imaginary parts
    assert rows.shape[0] > 10 and np.allclose(gh, gain[0] * plant(1j * rows[:, 0]), rtol=1e-10)

"""`loopcraft analyze` on what engineers type: negative leading signs, delays,
tables, w-plane loops; output that never runs columns together."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from tui.cli import main


def _run(capsys, *args) -> tuple[int, str, str]:
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_a_leading_minus_sign_is_an_expression_not_an_option(capsys):
    code, out, err = _run(capsys, "analyze", "--tf", "-2/(s+1)", "--json")
    assert code == 0, err
    assert json.loads(out)["gain_margins"][0]["gain_db"] == pytest.approx(-20 * math.log10(2), abs=1e-12)


def test_delay_option_and_factor_give_the_delay_margin_of_the_delayed_loop(capsys):
    _, a, _ = _run(capsys, "analyze", "--tf", "2/(s*(s+1))", "--delay", "0.1", "--json")
    _, b, _ = _run(capsys, "analyze", "--tf", "2/(s*(s+1))*exp(-0.1*s)", "--json")
    a, b = json.loads(a), json.loads(b)
    assert a["delay_margin"] == b["delay_margin"]
    # the delay margin of the undelayed loop less the added 0.1 s
    _, plain, _ = _run(capsys, "analyze", "--tf", "2/(s*(s+1))", "--json")
    assert a["delay_margin"] == pytest.approx(json.loads(plain)["delay_margin"] - 0.1, rel=1e-9)


def test_a_delay_that_is_not_a_factor_is_refused(capsys):
    code, _, err = _run(capsys, "analyze", "--tf", "1/(s+1)+exp(-s)")
    assert code == 2 and "factor" in err


def test_table_analysis_is_refined_on_a_fit_and_says_so(capsys, tmp_path):
    w = np.geomspace(0.01, 100, 400)
    gh = 10 / (1j * w * (1j * w + 1) * (1j * w + 5))
    rows = "".join(f"{float(a)!r},{float(abs(g))!r},{float(np.degrees(np.angle(g)))!r}\n" for a, g in zip(w, gh))
    (tmp_path / "plant.csv").write_text("w,mag,phase\n" + rows)
    code, out, err = _run(
        capsys, "analyze", "--table", str(tmp_path / "plant.csv"), "--columns", "w", "mag", "phase", "--json"
    )
    assert code == 0, err
    data = json.loads(out)
    assert data["method"].startswith("fitted (residual")
    # 10/(s(s+1)(s+5)): phase crossover at sqrt 5, GM = 20 log10(3) dB
    (gm,) = data["gain_margins"]
    assert gm["frequency"] == pytest.approx(math.sqrt(5), rel=1e-8)
    assert gm["gain_db"] == pytest.approx(20 * math.log10(3), rel=1e-8)
    code, _, err = _run(capsys, "analyze", "--table", str(tmp_path / "missing.csv"), "--columns", "w", "a", "b")
    assert code == 2 and "missing.csv" in err


def test_w_plane_output_says_w_plane_and_samples(capsys):
    z = "((1+w)/(1-w))"
    code, out, _ = _run(capsys, "analyze", "--variable", "w", "--tf", f"0.2*({z}+0.5)/(({z}-1)*({z}-0.5))")
    assert code == 0 and "w-plane rad/s" in out and "samples" in out and "closed loop: stable" in out


def test_columns_never_run_together(capsys):
    _, out, _ = _run(capsys, "analyze", "--tf", "1e9/((s+1e-6)*(s+1e6))")
    for line in out.splitlines():
        if re.match(r"^[GPS] ", line):
            cells = line.split()
            assert all(re.fullmatch(r"[-+0-9.e]+|inf|-inf|-|dB|deg", c) for c in cells[1:]), line


@pytest.mark.parametrize(
    "expression, said",
    [
        ("s^2+", "'+' at the end has nothing after it at column 4"),
        ("(1+s)/(s*(s+2))*", "'*' at the end has nothing after it at column 16"),
        ("0.5s", "write 0.5*s for a product at column 4"),
        ("10/(s*(2.5e-2s+1))", "write 2.5e-2*s for a product at column 14"),
        ("0", "L1 = '0' is 0 at every frequency: the loop is open"),
        ("0*(s+1)/(s+2)", "is 0 at every frequency"),
    ],
)
def test_expression_errors_point_at_the_real_place_and_a_zero_loop_is_refused(capsys, expression, said):
    assert main(["analyze", "--tf", expression]) == 2
    err = capsys.readouterr().err
    assert said in err and "Traceback" not in err


def test_a_table_in_db_is_read_as_db_and_a_negative_linear_magnitude_is_refused(capsys, tmp_path):
    """Issue 37 section 5: the form 'db'; a dB column read as linear gave a GM of 193 dB."""
    w = np.geomspace(0.01, 100, 400)
    gh = 10 / (1j * w * (1j * w + 1) * (1j * w + 5))
    rows = "".join(
        f"{float(a)!r},{float(20 * np.log10(abs(g)))!r},{float(np.degrees(np.angle(g)))!r}\n" for a, g in zip(w, gh)
    )
    (tmp_path / "plant_db.csv").write_text("w,mag_db,phase\n" + rows)
    table = ["analyze", "--table", str(tmp_path / "plant_db.csv"), "--columns", "w", "mag_db", "phase"]
    code, out, err = _run(capsys, *table, "--form", "db", "--json")
    assert code == 0, err
    (gm,) = json.loads(out)["gain_margins"]
    assert gm["gain_db"] == pytest.approx(20 * math.log10(3), rel=1e-8)
    code, _, err = _run(capsys, *table)  # the default form, polar: linear magnitudes
    row = next(k for k, g in enumerate(gh) if 20 * np.log10(abs(g)) < 0) + 1
    assert code == 2 and f"row {row} of column 'mag_db'" in err and "form 'db'" in err


def test_a_table_without_its_columns_is_one_plain_line(capsys, tmp_path):
    (tmp_path / "t.csv").write_text("w,mag,phase\n1,2,-90\n2,1,-120\n")
    assert main(["analyze", "--table", str(tmp_path / "t.csv"), "--allow-outside-tables"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        "--table: csv tables need three column names: frequency, first, second (two for form 'magnitude')"
    )
    assert "Value error" not in err and "\n" not in err


def test_a_loop_in_z_is_analyzed_in_rad_per_s_with_its_sample_time(capsys):
    """analyze --variable z --sample-time T (issue 39): the margins python-control finds
    on the same discrete loop (dt = T), the gain margin at the Nyquist frequency it leaves
    out (L(-1) < 0 there), the delay margin in seconds and samples, poles in z."""
    import control as ct
    import numpy as np

    from tui.cli import main

    T = 0.1
    assert (
        main(["analyze", "--variable", "z", "--sample-time", str(T), "--tf", "0.2*(z+0.8)/((z-1)*(z-0.6))", "--json"])
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    gm, pm, _, wg, wp, _ = ct.stability_margins(ct.tf([0.2, 0.16], np.polymul([1, -1], [1, -0.6]), T))
    gains = {round(g["frequency"], 9): g["gain_db"] for g in data["gain_margins"]}
    assert gains[round(wg, 9)] == pytest.approx(20 * np.log10(gm), rel=1e-9)
    nyquist = round(np.pi / T, 9)
    value = 0.2 * (-1 + 0.8) / ((-1 - 1) * (-1 - 0.6))  # L(-1), real and negative
    assert value < 0 and gains[nyquist] == pytest.approx(-20 * np.log10(abs(value)), rel=1e-9)
    (phase,) = data["phase_margins"]
    assert phase["frequency"] == pytest.approx(wp, rel=1e-9) and phase["phase_deg"] == pytest.approx(pm, rel=1e-9)
    assert data["delay_margin_samples"] == pytest.approx(data["delay_margin"] / T, rel=1e-12)
    poles = [complex(p["real"], p["imag"]) for p in data["closed_loop_poles"]]
    expected = np.roots(np.polyadd(np.polymul([1, -1], [1, -0.6]), [0.2, 0.16]))
    assert np.allclose(sorted(poles, key=lambda z: z.imag), sorted(expected, key=lambda z: z.imag), rtol=1e-9)
    assert data["closed_loop_stable"] is True and data["sample_time"] == T
    assert main(["analyze", "--variable", "z", "--tf", "z/(z-0.5)"]) == 2
    assert "--variable z needs --sample-time" in capsys.readouterr().err
    assert main(["analyze", "--sample-time", "0.1", "--tf", "1/(s+1)"]) == 2
    assert "give --variable z" in capsys.readouterr().err
    assert main(["analyze", "--variable", "z", "--sample-time", "0.1", "--tf", "0.5/(z*(z+1))"]) == 2
    assert "a pole at z = -1" in capsys.readouterr().err


def test_a_continuous_block_held_and_sampled_is_analyzed_in_z(capsys):
    """--held 1/(s(s+1)) --sample-time 0.2: zero-order hold (engine/model/discretize.py,
    checked against scipy in its own tests), its margins python-control's on
    control.c2d(G, T, 'zoh') where both list them (the crossings below Nyquist)."""
    import control as ct

    from tui.cli import main

    T = 0.2
    args = ["analyze", "--variable", "z", "--sample-time", str(T), "--held", "1/(s*(s+1))", "--tf", "2", "--json"]
    assert main(args) == 0
    data = json.loads(capsys.readouterr().out)
    gm, pm, _, wg, wp, _ = ct.stability_margins(2 * ct.c2d(ct.tf([1], [1, 1, 0]), T, "zoh"))
    (phase,) = data["phase_margins"]
    assert phase["frequency"] == pytest.approx(wp, rel=1e-8) and phase["phase_deg"] == pytest.approx(pm, rel=1e-8)
    gains = [g for g in data["gain_margins"] if abs(g["frequency"] - wg) <= 1e-8 * wg]
    assert gains and gains[0]["gain_db"] == pytest.approx(20 * math.log10(gm), rel=1e-8)
    assert main([*args[:-1], "--delay", "0.05", "--discretize", "tustin"]) == 2
    assert "discretized with its hold" in capsys.readouterr().err


@pytest.mark.parametrize(
    "args",
    [["--tf", "exp(-2e6*s)/s"], ["--tf", "exp(-6e5*s)/(s+1)", "--delay", "5e5"], ["--tf", "1/s", "--delay", "2e6"]],
)
def test_a_loop_delay_over_a_million_seconds_is_refused(capsys, args):
    """--delay over 1e6 s was refused, the same delay as an exp(-T*s) factor analyzed (issue 49)."""
    assert main(["analyze", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "1e+06" in err and "Traceback" not in err

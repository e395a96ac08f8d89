"""`loopcraft analyze`: the disk margin, sensitivity peaks, poles with zeta and
wn, and the root locus (--locus gain, --locus NAME with --param), as JSON and text."""

from __future__ import annotations

import json
import math

import pytest

from tui.cli import main


def _run(capsys, *args) -> tuple[int, str, str]:
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_json_has_the_disk_margin_and_the_peaks(capsys):
    # L = 4/(s (s + 2)): T = 4/(s^2 + 2 s + 4), zeta = 0.5: Mt = 1/(2 zeta sqrt(1 - zeta^2)) = 2/sqrt 3
    code, out, err = _run(capsys, "analyze", "--tf", "4/(s*(s+2))", "--json")
    assert code == 0, err
    data = json.loads(out)
    mt = data["complementary_sensitivity_peak"]
    assert mt["value"] == pytest.approx(2 / math.sqrt(3), rel=1e-13)
    assert mt["frequency"] == pytest.approx(2 * math.sqrt(0.5), rel=1e-9)
    assert mt["db"] == pytest.approx(20 * math.log10(2 / math.sqrt(3)), rel=1e-12)
    ms = data["sensitivity_peak"]
    assert ms["value"] > 1 and ms["method"] == "refined"
    disk = data["disk_margin"]
    assert set(disk) >= {"alpha", "skew", "gain_margin_low", "gain_margin_high", "phase_margin_deg", "frequency"}
    assert disk["skew"] == 0.0 and 0 < disk["alpha"] <= 2
    # balanced disk: phase margin 2 atan(alpha/2), gain factors reciprocal
    assert disk["phase_margin_deg"] == pytest.approx(math.degrees(2 * math.atan(disk["alpha"] / 2)), rel=1e-12)
    assert disk["gain_margin_low"] * disk["gain_margin_high"] == pytest.approx(1.0, rel=1e-13)
    for pole in data["closed_loop_poles"]:  # s^2 + 2 s + 4: wn 2, zeta 0.5
        assert pole["wn"] == pytest.approx(2.0, rel=1e-14) and pole["zeta"] == pytest.approx(0.5, rel=1e-14)
    assert "root_locus" not in data


def test_skew_option_and_text_lines(capsys):
    code, out, err = _run(capsys, "analyze", "--tf", "4/(s*(s+2))", "--skew", "1")
    assert code == 0, err
    assert "disk margin (skew 1): alpha" in out
    assert "sensitivity peak Ms:" in out and "complementary peak Mt: 1.1547" in out


def test_gain_locus_crossings_are_the_gain_margins(capsys):
    # 1/(s (s + 1)(s + 2)): crossing at k = 6, w = sqrt 2 (Routh); GM = 20 log10 6 dB
    code, out, err = _run(capsys, "analyze", "--tf", "1/(s*(s+1)*(s+2))", "--json", "--locus", "gain")
    assert code == 0, err
    data = json.loads(out)
    locus = data["root_locus"]
    (c,) = locus["crossings"]
    assert c["value"] == pytest.approx(6.0, rel=1e-12) and c["frequency"] == pytest.approx(math.sqrt(2), rel=1e-12)
    assert 20 * math.log10(c["value"]) == pytest.approx(data["gain_margins"][0]["gain_db"], rel=1e-12)
    assert len(locus["branches"]) == 3 and all(len(b) == len(locus["values"]) for b in locus["branches"])
    assert all(len(point) == 2 for point in locus["branches"][0])
    assert locus["asymptotes"] == {"centroid": pytest.approx(-1.0), "angles_deg": [60.0, 180.0, 300.0]}
    assert locus["current_value"] == 1.0 and len(locus["current_poles"]) == 3
    assert locus["status"] == "complete"


def test_parameter_locus_and_its_text(capsys):
    code, out, err = _run(capsys, "analyze", "--tf", "K/(s*(s+8)*(s+20))", "--param", "K=1000", "--locus", "K")
    assert code == 0, err
    assert "root locus in K:" in out and "imaginary-axis crossing: K = 4480" in out
    code, out, err = _run(
        capsys,
        "analyze",
        "--tf",
        "K/(s*(s+8)*(s+20))",
        "--param",
        "K=1000",
        "--locus",
        "K",
        "--locus-range",
        "1000",
        "5000",
        "--json",
    )
    assert code == 0, err
    locus = json.loads(out)["root_locus"]
    assert locus["values"][0] == pytest.approx(1000) and locus["values"][-1] == pytest.approx(5000)
    assert locus["crossings"][0]["value"] == pytest.approx(4480.0, rel=1e-12)


@pytest.mark.parametrize(
    "args, message",
    [
        (("--tf", "K/(s+1)"), "--param NAME=VALUE"),
        (("--tf", "K/(s+1)", "--param", "K"), "NAME=VALUE"),
        (("--tf", "K/(s+1)", "--param", "K=nan"), "finite"),
        (("--tf", "1/(s+1)", "--locus", "x"), "no parameter 'x'"),
        (("--tf", "1/(s+1)", "--locus", "gain", "--locus-range", "2", "1"), "range"),
        (("--tf", "1/(s+1)*exp(-0.1*s)", "--locus", "gain"), "rational"),
        (("--tf", "1/(s+1)", "--skew", "inf"), "skew"),
    ],
)
def test_bad_requests_are_named_errors(capsys, args, message):
    code, _, err = _run(capsys, "analyze", *args)
    assert code == 2 and message in err and "Traceback" not in err

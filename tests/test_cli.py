"""The `loopcraft` command line, run as a subprocess the way a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

CMD = [sys.executable, "-m", "tui.cli"]


def run(*args):
    return subprocess.run(CMD + list(args), capture_output=True, text=True, timeout=120)


def test_analyze_json_report_003():
    out = run("analyze", "--tf", "16000/(s*(s+8)*(s+20))", "--tf", "(s+1)*(s+5)/((s+0.1)*(s+50))", "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    (pm,), (gm,) = data["phase_margins"], data["gain_margins"]
    assert pm["phase_deg"] == pytest.approx(52.13, abs=0.005)
    assert gm["gain_db"] == pytest.approx(14.11, abs=0.005)
    assert data["crossover_frequency"] == pytest.approx(12.06, abs=0.005)
    assert data["closed_loop_stable"] is True
    assert len(data["closed_loop_poles"]) == 5
    assert {"frequency", "distance"} <= set(data["stability_margins"][0])
    assert pm["distance"] == pytest.approx(
        abs(2 * __import__("math").sin(__import__("math").radians(pm["phase_deg"]) / 2))
    )


def test_analyze_text_table():
    out = run("analyze", "--tf", "16000/(s*(s+8)*(s+20))")
    assert out.returncode == 0
    assert "-28.5863 deg" in out.stdout and "-11.0568 dB" in out.stdout
    assert "closed loop: unstable" in out.stdout


@pytest.mark.parametrize("expr", ["16000/(s*(s+8)(s+20))", "2s+1", "s**0.5", "__import__('os')", "K/s"])
def test_bad_expression_exits_2_with_one_line(expr):
    out = run("analyze", "--tf", expr)
    assert out.returncode == 2
    assert out.stdout == ""
    assert len(out.stderr.strip().splitlines()) == 1
    assert "Traceback" not in out.stderr


def test_help_lists_the_commands_and_the_app():
    out = run("--help")
    assert out.returncode == 0 and "analyze" in out.stdout and "--example" in out.stdout


def test_a_missing_session_file_for_the_app_is_one_line():
    out = run("nonexistent.json")
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "no such file" in out.stderr


def _modules_after(code: str) -> set[str]:
    """The top-level modules a fresh interpreter has imported after ``code``."""
    script = f"import sys\n{code}\nprint('MODULES:', ' '.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=True)
    return set(out.stdout.split("MODULES:")[-1].split())


@pytest.mark.slow
def test_the_command_line_does_not_build_the_app():
    """Importing the CLI, `--help` and `analyze` load neither Textual nor an algorithm;
    a cip run loads the cip package alone."""
    bundled = ("engine.cip", "engine.qcg", "engine.slp", "engine.projection")
    imported = _modules_after("import tui.cli")
    assert not {m for m in imported if m.split(".")[0] in ("textual", "textual_plotext", "plotext")}
    assert not imported & set(bundled)
    analyzed = _modules_after("from tui.cli import main\nmain(['analyze', '--tf', '1/(s+1)**2'])")
    assert not {m for m in analyzed if m.startswith(("textual", "scipy.optimize", "distributed"))}
    assert not analyzed & set(bundled)
    examples = __import__("pathlib").Path(__file__).resolve().parents[1] / "sessions" / "examples"
    ran = _modules_after(f"from tui.cli import main\nmain(['report', {str(examples / 'report003_lag_lead.json')!r}])")
    assert "engine.cip" in ran and not ran & {"engine.qcg", "engine.slp", "engine.projection"}
    assert not {m for m in ran if m.startswith("textual")}


def test_the_app_without_a_terminal_exits_2_at_once(tmp_path):
    """Output to a pipe (``loopcraft x.json | head``) or input from one: the app
    would draw for no one and spin; it says why and exits 2 instead."""
    import shutil
    from pathlib import Path

    session = tmp_path / "report003_lag_lead.json"
    shutil.copy2(Path(__file__).resolve().parent.parent / "sessions" / "examples" / session.name, session)
    out = subprocess.run(CMD + [str(session)], capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
    assert out.returncode == 2
    assert out.stderr.startswith(
        "loopcraft: error: the workbench needs a terminal: standard input and output are not terminals"
    )
    assert "Traceback" not in out.stderr and out.stdout == ""


@pytest.mark.long
@pytest.mark.slow
def test_unbounded_peaks_are_null_in_json_and_named_in_text():
    """1/s^2 closes with poles at +-1j: Ms and Mt are infinite; JSON has no
    infinities, so the value is null with "unbounded": true (strict JSON)."""
    out = run("analyze", "--tf", "1/s^2", "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout, parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    for key in ("sensitivity_peak", "complementary_sensitivity_peak"):
        assert data[key]["value"] is None and data[key]["unbounded"] is True
        assert data[key]["frequency"] == pytest.approx(1.0, rel=1e-9)
    finite = json.loads(run("analyze", "--tf", "1600/(s*(s+8)*(s+20))", "--json").stdout)  # a stable loop
    assert finite["sensitivity_peak"]["unbounded"] is False and finite["sensitivity_peak"]["value"] > 1
    text = run("analyze", "--tf", "1/s^2").stdout
    assert "sensitivity peak Ms: inf (unbounded) at 1 rad/s" in text and "note: unbounded: 1 + GH is 0" in text


def test_sweep_json_keeps_the_keys_other_programs_read():
    """The saved names changed in version 2 (ranking, desired); `sweep --json` prints
    the former keys beside them."""
    from tui.cli.sweep import with_former_keys

    summary = {
        "runs": [{"index": 0, "ranking": 2.0, "measures": [{"name": "P1", "desired": 45.0}]}],
        "optima": [{"ranking": 2.0}],
        "worst_case": [{"name": "P1", "desired": 45.0}],
    }
    printed = with_former_keys(summary)
    assert printed["runs"][0]["objective"] == printed["runs"][0]["ranking"] == 2.0
    assert printed["runs"][0]["measures"][0]["target"] == 45.0 and printed["optima"][0]["objective"] == 2.0
    assert printed["worst_case"][0]["target"] == printed["worst_case"][0]["desired"] == 45.0


def test_an_unstable_closed_loop_has_unbounded_peaks_and_no_delay_margin():
    """16000/(s(s+8)(s+20)) closes unstable: Ms, Mt unbounded (S and T have right-half-plane
    poles) and the delay margin 0, each said; the finite peaks on the axis are kept, labelled
    (analyze printed Ms 2.03, Mt 2.36 and a delay margin of 0.258 s without a word)."""
    data = json.loads(run("analyze", "--tf", "16000/(s*(s+8)*(s+20))", "--json").stdout)
    assert data["verdict"] == "unstable"
    for key in ("sensitivity_peak", "complementary_sensitivity_peak"):
        assert data[key]["unbounded"] is True and any("on the axis" in n for n in data[key]["notes"])
    assert data["delay_margin"] == 0.0 and any("unstable" in n for n in data["notes"])
    text = run("analyze", "--tf", "16000/(s*(s+8)*(s+20))").stdout
    assert "delay margin: 0 s" in text and "sensitivity peak Ms: inf (unbounded); peak of |S| on the axis 2.03" in text


def test_a_tolerance_sweep_prints_its_worst_cases_and_optima_their_notes():
    """The worst case's desired value is 'desired' since version 2 (the text read 'target');
    an optimum at a bound says so under its line."""
    from tui.cli.sweep import sweep_text

    base = {
        "kind": "tolerance",
        "algorithm": "slp",
        "workers": 1,
        "settings": {},
        "cancelled": False,
        "failed": [],
        "retried": {},
    }
    row = {"name": "GM1", "kind": "gain_margin_db", "condition": "c", "worst": 5.0, "desired": 6.0}
    text = sweep_text({**base, "runs": [], "optima": [], "worst_case": [{**row, "unmet_samples": 3, "samples": 8}]})
    assert "GM1" in text and "3/8" in text
    optimum = {"count": 2, "meets_requirements": True, "ranking": 1.0, "best_run": 0, "parameters": {"T2": 1e-4}}
    text = sweep_text(
        {**base, "kind": "starts", "runs": [], "optima": [{**optimum, "notes": ["T2 at its lower bound 0.0001"]}]}
    )
    assert "note: T2 at its lower bound 0.0001" in text

"""The python-control export of a condition with several loop breaks (issue 57): the script
rebuilds the loop at each break with the other loops closed (interconnect joins them by name)
and prints python-control's margins there beside loopcraft's; they agree to 1e-9 on the
two-path autopilot (tests/sessions/test_two_path_breaks), whose loop at u_att is also
python-control's -KA/s * feedback(B A, R, +1) written in the test.  python-control's
grid-based disk_margins is the comparison of each break's disk margin, and of the multi-loop
one only with slycot (its MIMO disk_margins needs ab13md): without it the script says so."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys

import pytest

from sessions.export.formats import export_text
from sessions.store import load_session
from tests.sessions.test_two_path_breaks import document, loop_at_u_att, phase_margin

control = pytest.importorskip("control")


@pytest.fixture(scope="module")
def script(tmp_path_factory):
    folder = tmp_path_factory.mktemp("breaks")
    (folder / "two_paths.json").write_text(json.dumps(document()))
    path = folder / "two_paths.py"
    path.write_text(export_text(load_session(folder / "two_paths.json"), None, "python"))
    return path


def run(script, *args: str) -> str:
    done = subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


def rounding_at_dc(db: float, w: float) -> bool:
    """python-control's phase crossover at 0 rad/s of a loop with a zero at s = 0 (the loop at
    u_rate: L(0) = 0), where |L| is the rounding of its polynomial evaluation (1.3e-15 with
    python-control 0.10.2 and numpy 2.4.6, a "gain margin" of 298 dB; the stop-65 CI's
    install did not report it): not a crossing of the loop, and loopcraft reports none.  A
    margin above 240 dB (|L| below 1e-12) at 0 rad/s is such a rounding."""
    return w == 0.0 and db > 240.0


def test_the_script_reproduces_every_break_s_margins_with_the_others_closed(script):
    cruise = json.loads(run(script, "--json"))["cruise"]
    ours = cruise["loopcraft"]["breaks"]
    assert list(cruise["breaks"]) == ["dc", "u_att", "u_rate"]
    for cut, theirs in cruise["breaks"].items():
        gains = [
            (db, w)
            for db, w in zip(theirs["gain_margins_db"], theirs["phase_crossovers"])
            if db is not None and not rounding_at_dc(db, w)
        ]
        phases = list(zip(theirs["phase_margins_deg"], theirs["gain_crossovers"]))
        for kind, found in (("gain", gains), ("phase", phases)):
            assert len(found) == len(ours[cut][kind]), (cut, kind)
            for (value, w), (mine, at) in zip(sorted(found, key=lambda p: p[1]), ours[cut][kind]):
                assert value == pytest.approx(mine, abs=1e-9) and w == pytest.approx(at, rel=1e-9), (cut, kind)
        assert theirs["disk_margin_grid"] >= ours[cut]["disk"] - 1e-12  # a grid misses the peak: alpha above
        assert theirs["disk_margin_grid"] == pytest.approx(ours[cut]["disk"], rel=1e-4)
    pm, wc = phase_margin(loop_at_u_att(1.0, 0.1))  # the loop at u_att written independently
    assert cruise["breaks"]["u_att"]["phase_margins_deg"] == pytest.approx([pm], abs=1e-9)
    assert cruise["breaks"]["u_att"]["gain_crossovers"] == pytest.approx([wc], rel=1e-9)


def test_the_script_says_where_python_control_s_disk_margins_is_compared(script):
    text = run(script)
    assert "at break u_att (the other loops closed):" in text
    assert "disk_margins on 2000 points, grid-based" in text
    if importlib.util.find_spec("slycot") is None:
        assert "not compared: python-control's MIMO disk_margins needs slycot (ab13md), not installed" in text
    else:
        assert "slycot's mu bound" in text

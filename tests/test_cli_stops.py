"""Every stop names its cause in words and data (issue 51, section 2), as `loopcraft run`
prints it and the workbench's status line shows it (`Workbench.status_text`): every desired
value reached (what to do to polish further), a constraint that binds, a parameter held at a
bound, the requirements left unmet, an iteration limit."""

from __future__ import annotations

import json

import pytest

from sessions.store import load_session
from tui.cli import main
from tui.state.workbench import Workbench


def _run(capsys, *args) -> tuple[int, str, str]:
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def _session(tmp_path, capsys, compensator: str, values: dict, targets: list[dict], bounds: dict | None = None):
    path = tmp_path / f"{compensator}.json"
    assert _run(capsys, "new", str(path), "--plant", "1/(s*(s+1))", "--compensator", compensator)[0] == 0
    data = json.loads(path.read_text())
    for p in data["problem"]["parameters"]:
        p["value"] = values.get(p["name"], p["value"])
        p["min"], p["max"] = (bounds or {}).get(p["name"], (p["min"], p["max"]))
    data["problem"]["targets"] = targets
    path.write_text(json.dumps(data))
    return path


def _target(measure: str, desired: float) -> dict:
    scale = {"phase_margin_deg": 0.2}.get(measure, 1.0)  # the template's: a degree weighs a fifth
    return {"measure": measure, "bands": [{"desired": desired}], "scale": scale}


def test_a_design_that_reaches_every_desired_value_says_how_to_polish_further(tmp_path, capsys):
    # K = 1 on 1/(s(s+1)): PM 51.8 deg (180 - 90 - atan(0.786)), no phase crossing
    path = _session(tmp_path, capsys, "gain", {"K": 1.0}, [_target("phase_margin_deg", 45.0)])
    code, out, _ = _run(capsys, "run", str(path), "--until-done")
    assert code == 0 and "slp: iteration 1, converged" in out
    assert "stopped: every requirement met and every desired value reached at the start" in out
    assert "stop: every desired value reached: raise one to polish further (Targets tab: 3, then e on a target" in out


def test_a_stalled_run_names_the_constraint_that_binds_and_what_is_unmet(tmp_path, capsys):
    # a lead's phase lead is capped by T1 <= 20*T2: PM 80 deg with a crossover of 5 rad/s is out of reach
    targets = [_target("phase_margin_deg", 80.0), _target("crossover_frequency", 5.0)]
    path = _session(tmp_path, capsys, "lead", {}, targets)
    code, out, _ = _run(capsys, "run", str(path), "--until-done")
    assert code == 0 and ", no further improvement" in out.splitlines()[0]
    assert "stop: 'T1 <= 20*T2' binds" in out
    assert "stop: unmet: WC1 (crossover_frequency, nominal)" in out and "< 5" in out
    bench = Workbench(load_session(path))
    assert "'T1 <= 20*T2' binds" in bench.status_text() and "unmet: WC1" in bench.status_text()


def test_a_stalled_run_names_the_parameter_held_at_its_bound(tmp_path, capsys):
    # K <= 0.5 on 1/(s(s+1)): the crossover is at most 0.46 rad/s (K = w sqrt(1 + w^2)), 1 is out of reach
    path = _session(tmp_path, capsys, "gain", {"K": 0.1}, [_target("crossover_frequency", 1.0)], {"K": (0.01, 0.5)})
    code, out, _ = _run(capsys, "run", str(path), "--until-done")
    assert code == 0 and "stop: K at its upper bound 0.5" in out
    assert "stop: unmet: WC1 (crossover_frequency, nominal) 0.4" in out


@pytest.mark.parametrize("limit", [1, 2])
def test_an_iteration_limit_says_so_with_what_is_unmet(tmp_path, capsys, limit):
    targets = [_target("phase_margin_deg", 45.0), _target("crossover_frequency", 0.9)]
    path = _session(tmp_path, capsys, "gain", {"K": 0.05}, targets, {"K": (0.01, 10.0)})
    code, out, _ = _run(capsys, "run", str(path), "--until-done", "--set", f"max_major={limit}")
    assert code == 0 and "iteration limit" in out.splitlines()[0]
    assert f"stopped: major-iteration limit ({limit})" in out and "stop: unmet: WC1" in out


def test_a_stalled_run_names_the_requirement_that_holds_it(tmp_path, capsys):
    # K/(s(s+1)): PM >= 45 deg caps the crossover at 1 rad/s (PM = 90 - atan(wc)), asked for 1
    targets = [_target("phase_margin_deg", 45.0), _target("crossover_frequency", 1.0)]
    path = _session(tmp_path, capsys, "gain", {"K": 0.05}, targets, {"K": (0.01, 10.0)})
    code, out, _ = _run(capsys, "run", str(path), "--until-done")
    assert code == 0 and "stop: holds: PM1 (phase_margin_deg, nominal) 45." in out
    assert "at its requirement 45" in out and "stop: unmet: WC1" in out

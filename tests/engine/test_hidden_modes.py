"""Fixed (hidden) modes: closed-loop poles uncontrollable or unobservable from the loop are named as
such, in `analyze` (text and JSON), the report's pole table and the app's pole lines.  References:
the modes stay where they are when a compensator gain changes (they are fixed), and their number in
each group of equal poles is the one the eigenvector form of the PBH test gives (scipy's left and
right eigenvectors: w^H b = 0, c v = 0), not the rank test the code uses."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import eig

from engine.analysis import analyze, fixed_modes, unity_feedback
from engine.closed_loop.poles import closed_loop_poles
from engine.loop.pole_zero import loop_realization
from sessions.store import load_session
from tests.engine.many_pole_loops import factor_roots, many_pole_loop
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _condition(name: str, c: int = 0):
    problem = load_session(EXAMPLES / name).problem
    condition = problem.conditions[c]
    return condition, problem.grid.omega, dict(problem.condition_values(c))


def _eigenvector_count(A, b, c, cluster: np.ndarray) -> int:
    """Hidden copies among a group of equal eigenvalues by the eigenvector test."""
    values, left, right = eig(A, left=True, right=True)
    at = [int(np.argmin(np.abs(values - p))) for p in cluster]
    W, V = left[:, at], right[:, at]
    # unit eigenvectors: the hidden modes' |w^H b|/|b| and |c v|/|c| are 1e-14 or less on the launch vehicle,
    # the others' 2.4e-6 or more
    tol = 1e-10
    uncontrollable = len(at) - np.linalg.matrix_rank(W.conj().T @ b[:, None], tol=tol * np.linalg.norm(b))
    unobservable = len(at) - np.linalg.matrix_rank(c[None, :] @ V, tol=tol * np.linalg.norm(c))
    return max(uncontrollable, unobservable)


def test_a_pole_cancelled_by_its_zero_is_named_a_fixed_mode(capsys):
    """coebra_kuo_z at T1 = T2 = 20: the compensator's pole 19/21 is cancelled by its zero; it was
    reported as 'not a root ... digits not to be trusted'."""
    assert main(["analyze", str(EXAMPLES / "coebra_kuo_z.json"), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    fixed = [p for p in data["closed_loop_poles"] if p["fixed"]]
    assert len(fixed) == 1 and fixed[0]["real"] == pytest.approx(19 / 21, rel=1e-9) and fixed[0]["imag"] == 0
    assert not any("not to be trusted" in n for n in data["notes"])
    assert any("fixed (hidden) mode" in n and "0.904762" in n for n in data["notes"])
    assert main(["analyze", str(EXAMPLES / "coebra_kuo_z.json")]) == 0
    assert "fixed: unobservable from the loop" in capsys.readouterr().out


@pytest.mark.parametrize("name, gain", [("coebra_launch_vehicle.json", "KD"), ("coebra_kuo_z.json", "T2")])
def test_fixed_modes_stay_put_and_count_as_the_eigenvector_test_says(name, gain):
    condition, omega, values = _condition(name)
    found = analyze(condition.network, condition.break_at, omega, values)
    poles = np.array([p.value for p in closed_loop_poles(condition.network, values)])
    hidden = fixed_modes(condition.network, condition.break_at, values, closed_loop_poles(condition.network, values))
    assert any(hidden) and len(found.hidden) == len(found.closed_loop_poles)
    moved = dict(values, **{gain: values[gain] * 1.5})
    after = np.array([p.value for p in closed_loop_poles(condition.network, moved)])
    if name.startswith("coebra_launch"):  # a fixed mode does not move with the compensator's gain
        for p in poles[[bool(h) for h in hidden]]:
            assert np.min(np.abs(after - p)) <= 1e-7 * abs(p)
    ss = loop_realization(condition.network, condition.break_at, values)
    k = condition.network.signal(condition.break_at)
    b, c = ss.B[:, -1], ss.C[k] / (1.0 - ss.D[k, -1])
    A = ss.A + np.outer(b, c)
    done: set[int] = set()
    for i, p in enumerate(poles):
        if i in done:
            continue
        cluster = [j for j, q in enumerate(poles) if abs(q - p) <= 1e-6 * max(abs(p), 1.0)]
        done.update(cluster)
        expected = _eigenvector_count(A, b, c, poles[cluster])
        assert sum(bool(hidden[j]) for j in cluster) == expected, (p, len(cluster))


@pytest.mark.long
def test_the_launch_vehicle_s_bending_copies_are_labelled_in_the_report_table(tmp_path):
    assert main(["report", str(EXAMPLES / "coebra_launch_vehicle.json"), "--format", "md", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "coebra_launch_vehicle.md").read_text()
    rows = [line for line in text.splitlines() if line.startswith("| -0.57 +- 37.9957j")]
    assert rows and all("fixed: uncontrollable" in row for row in rows)


def test_the_app_s_pole_lines_name_the_fixed_mode():
    from tui.figures.closed_loop import pole_lines
    from tui.state.workbench import Workbench

    lines = pole_lines(Workbench(load_session(EXAMPLES / "coebra_kuo_z.json")).view()).splitlines()
    (fixed,) = [line for line in lines if "fixed:" in line]
    assert fixed.split()[0] == f"{19 / 21:.5g}" and "unobservable from the loop" in fixed


@pytest.mark.parametrize("seed", [100, 201, 205, 209, 235])
def test_a_many_pole_loop_without_common_factors_has_no_fixed_mode(seed):
    """A loop of 48-60 poles typed as one expression whose factors share no root (checked here:
    every zero 1e-3 or more from every pole, relative) is a minimal realization's transfer: no mode is
    uncontrollable or unobservable, whatever the gain moves.  The rank test alone named up to every
    pole of such loops fixed (57 of 57: modes the gain moved by 0.3 % to 92 %, and by less than 1e-8
    at small gains); seed 235's high gain puts 4 closed-loop poles on zeros, which were named fixed
    after the first fix."""
    loop = many_pole_loop(seed)
    zeros, poles = factor_roots(loop.zeros), np.concatenate([factor_roots(loop.poles), np.zeros(loop.integrators)])
    if zeros.size:
        assert np.min(np.abs(zeros[:, None] - poles[None, :]) / np.abs(poles[None, :] + 1e-300)) > 1e-3
    found = analyze(unity_feedback([loop.text]), "e", np.logspace(-2, 6, 200), {})
    assert len(found.hidden) == len(found.closed_loop_poles) == loop.order
    assert not any(found.hidden)
    assert not any("fixed (hidden)" in note for note in found.notes)

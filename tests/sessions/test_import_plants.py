"""`loopcraft new --plant-file F.mat|F.npz`: num/den, A/B/C/D and frequency-response
plants (fixtures written here with scipy.io.savemat and np.savez), checked against
python-control's own model of the same arrays; bad files exit 2 naming the file."""

from __future__ import annotations

import control
import numpy as np
import pytest
from scipy.io import savemat

from engine.loop.responses import open_loop
from sessions.store import load_session
from tui.cli import main

NUM, DEN = [2.0, 3.0], [1.0, 0.7, 4.0, 0.0]  # (2 s + 3)/(s^3 + 0.7 s^2 + 4 s)
A = np.array([[0.0, 1.0], [-4.0, -0.7]])
B, C, D = np.array([[0.0], [1.0]]), np.array([[3.0, 2.0]]), np.array([[0.5]])
W = np.array([0.2, 1.3, 7.0])


def _save(path, arrays):
    if path.suffix == ".mat":
        savemat(path, arrays)
    else:
        np.savez(path, **arrays)
    return path


def _plant_response(session_path, w):
    """The session's loop with the compensator at K = 1, T1 = T2 (gain structure: K = 1)."""
    session = load_session(session_path)
    condition = session.problem.conditions[0]
    return open_loop(condition.network, "e", w, session.problem.condition_values(0), sensitivities=False).value


@pytest.mark.parametrize("suffix", [".mat", ".npz"])
def test_num_den(tmp_path, suffix):
    source = _save(tmp_path / f"plant{suffix}", {"num": np.array(NUM), "den": np.array(DEN)})
    assert main(["new", "--plant-file", str(source), "--compensator", "gain", str(tmp_path / "s.json")]) == 0
    expected = control.tf(NUM, DEN)(1j * W)
    assert np.allclose(_plant_response(tmp_path / "s.json", W), expected, rtol=1e-13)


@pytest.mark.parametrize("suffix", [".mat", ".npz"])
def test_state_space(tmp_path, suffix):
    source = _save(tmp_path / f"ss{suffix}", {"A": A, "B": B, "C": C, "D": D})
    assert main(["new", "--plant-file", str(source), "--compensator", "gain", str(tmp_path / "s.json")]) == 0
    expected = control.ss(A, B, C, D)(1j * W)
    assert np.allclose(_plant_response(tmp_path / "s.json", W), expected, rtol=1e-12)


@pytest.mark.parametrize("suffix", [".mat", ".npz"])
def test_frequency_response_becomes_a_table_beside_the_session(tmp_path, suffix):
    freq = np.geomspace(0.01, 100.0, 200)
    resp = control.tf(NUM, DEN)(1j * freq)
    source = _save(tmp_path / f"frd{suffix}", {"freq": freq, "resp": resp})
    folder = tmp_path / "work"
    folder.mkdir()
    assert main(["new", "--plant-file", str(source), "--compensator", "gain", str(folder / "frd.json")]) == 0
    assert (folder / "frd_plant.csv").is_file()
    session = load_session(folder / "frd.json")
    block = session.model.problem.conditions[0].plant.blocks[1]
    assert block.transfer.kind == "table" and block.transfer.table.csv == "frd_plant.csv"
    got = _plant_response(folder / "frd.json", freq[[10, 100, 150]])
    assert np.allclose(got, resp[[10, 100, 150]], rtol=1e-12)  # at the table's own points


@pytest.mark.parametrize(
    "arrays, message",
    [
        ({"x": np.ones(3)}, "expected num and den"),
        ({"num": np.array([1.0]), "den": np.array([0.0])}, "den is zero"),
        ({"num": np.array([1.0, np.nan]), "den": np.array([1.0, 1.0])}, "finite numbers"),
        ({"A": np.ones((2, 3)), "B": np.ones((2, 1)), "C": np.ones((1, 2))}, "SISO state space"),
        ({"A": np.diag([-1 + 1j, -2]), "B": np.ones((2, 1)), "C": np.ones((1, 2))}, "A must be a matrix of real"),
        ({"A": -np.eye(2), "B": np.ones((2, 1)) * 1j, "C": np.ones((1, 2))}, "B must be a matrix of real"),
        ({"freq": np.array([1.0, 0.5]), "resp": np.array([1.0, 2.0])}, "freq increasing"),
    ],
)
def test_bad_arrays_exit_2_naming_the_file(tmp_path, capsys, arrays, message):
    source = _save(tmp_path / "bad.npz", arrays)
    assert main(["new", "--plant-file", str(source), str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err
    assert message in err and "bad.npz" in err and err.count("\n") == 1
    assert not (tmp_path / "s.json").exists()


def test_unreadable_files_exit_2(tmp_path, capsys):
    (tmp_path / "broken.mat").write_bytes(b"not a mat file at all")
    (tmp_path / "plant.txt").write_text("1 2 3")
    for name, message in (
        ("broken.mat", "cannot read"),
        ("plant.txt", "expected a .mat or .npz"),
        ("missing.npz", "no such file"),
    ):
        assert main(["new", "--plant-file", str(tmp_path / name), str(tmp_path / "s.json")]) == 2
        err = capsys.readouterr().err
        assert message in err and name in err


def test_a_pickled_npz_is_refused(tmp_path, capsys):
    """An object array needs pickle to load: np.load(allow_pickle=False) refuses it."""
    np.savez(tmp_path / "objects.npz", num=np.array([{"a": 1}], dtype=object), den=np.array([1.0]))
    assert main(["new", "--plant-file", str(tmp_path / "objects.npz"), str(tmp_path / "s.json")]) == 2
    assert "objects.npz" in capsys.readouterr().err

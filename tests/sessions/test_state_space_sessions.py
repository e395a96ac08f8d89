"""State-space blocks in sessions (issue 39, section 2): inline or from a .npz/.json
file beside the session, checked with errors naming the JSON path and the file;
`loopcraft new --plant-file` keeps A, B, C, D as a block; `loopcraft analyze --ss`;
the one-line form and the Plant tab's line.  References: python-control on the
same matrices."""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np
import pytest

from engine.loop.responses import open_loop
from sessions.build import OutsideTable
from sessions.errors import SessionError
from sessions.forms.one_line import FormError
from sessions.forms.transfers import describe_state_space, format_transfer, parse_transfer
from sessions.new.templates import new_session
from sessions.store import load_session
from tui.cli import main
from tui.state.plant_rows import plant_rows

A = np.array([[0.0, 1.0], [-4.0, -0.7]])
B, C, D = np.array([0.0, 1.0]), np.array([3.0, 2.0]), 0.5
INLINE = {"kind": "state_space", "A": A.tolist(), "B": B.tolist(), "C": C.tolist(), "D": D}
W = np.array([0.2, 1.3, 7.0])
PLANT = control.ss(A, B[:, None], C[None, :], D)


def _write(folder: Path, transfer: dict) -> Path:
    """A gain-compensated session (K = 1) on the plant ``transfer``, written in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "s.json"
    path.write_text(json.dumps(new_session(transfer, "gain")))
    return path


def _plant_response(path: Path, w: np.ndarray = W) -> np.ndarray:
    session = load_session(path)
    condition = session.problem.conditions[0]
    return open_loop(condition.network, "e", w, session.problem.condition_values(0), sensitivities=False).value


def test_an_inline_block_is_the_plant(tmp_path):
    assert np.allclose(_plant_response(_write(tmp_path, INLINE)), PLANT(1j * W).ravel(), rtol=1e-13)


@pytest.mark.parametrize("suffix", [".npz", ".json"])
def test_a_file_beside_the_session_is_the_plant(tmp_path, suffix):
    file = tmp_path / f"plant{suffix}"
    if suffix == ".npz":
        np.savez(file, A=A, B=B[:, None], C=C[None, :], D=np.array([[D]]))
    else:
        file.write_text(json.dumps({"A": A.tolist(), "B": B.tolist(), "C": C.tolist(), "D": D}))
    path = _write(tmp_path, {"kind": "state_space", "file": file.name})
    assert np.allclose(_plant_response(path), PLANT(1j * W).ravel(), rtol=1e-13)


@pytest.mark.parametrize(
    "transfer, message",
    [
        (INLINE | {"A": [[0.0, 1.0], [-4.0]]}, "A must be square: it has 2 rows, and row 2 has 1 numbers"),
        (INLINE | {"C": [1.0]}, "C has 1 numbers; with A 2 x 2 it must have 2"),
        (INLINE | {"file": "plant.npz"}, "give either A, B, C (and D) inline or a file, not both"),
        ({"kind": "state_space", "A": [[1.0]], "C": [1.0]}, "needs A, B and C (missing B)"),
        ({"kind": "state_space", "file": "missing.npz"}, "missing.npz"),
        ({"kind": "state_space", "file": "plant.txt"}, "a state space is read from a .npz or a .json file"),
    ],
)
def test_bad_blocks_are_refused_naming_their_json_path(tmp_path, transfer, message):
    path = _write(tmp_path, transfer)
    with pytest.raises(SessionError) as refused:
        load_session(path)
    text = str(refused.value)
    assert message in text and "conditions[0]" in text and "blocks[1]" in text and "transfer" in text


@pytest.mark.parametrize(
    "arrays, message",
    [
        ({"A": A, "B": np.ones((2, 2)), "C": C}, "plant.npz: B is 2 x 2; with A 2 x 2 it must be 2 x 1"),
        ({"A": A, "B": B, "C": C, "E": A}, "plant.npz holds A, B, C, E; a state space is A, B, C and optionally D"),
        ({"A": A, "B": B}, "holds A, B;"),
        ({"A": A, "B": B, "C": np.array([np.inf, 1.0])}, "C has a value that is not finite"),
        ({"A": A.astype(complex), "B": B, "C": C}, "A is not an array of real numbers"),
        ({"A": np.array([{"a": 1}], dtype=object), "B": B, "C": C}, "cannot read"),  # a pickle: refused
    ],
)
def test_bad_files_are_refused_naming_the_file_and_the_json_path(tmp_path, arrays, message):
    np.savez(tmp_path / "plant.npz", **arrays)
    with pytest.raises(SessionError) as refused:
        load_session(_write(tmp_path, {"kind": "state_space", "file": "plant.npz"}))
    assert message in str(refused.value) and "blocks[1].transfer" in str(refused.value)


def test_a_json_file_that_is_not_matrices_is_refused(tmp_path):
    for text, message in (
        ("[1, 2]", "expected an object"),
        ('{"A": [[1, 2], [3]]}', "A is not a matrix"),
        ("{", "not JSON"),
    ):
        (tmp_path / "plant.json").write_text(text)
        with pytest.raises(SessionError, match=message):
            load_session(_write(tmp_path, {"kind": "state_space", "file": "plant.json"}))


def test_a_file_outside_the_session_folder_is_refused_unless_allowed(tmp_path):
    np.savez(tmp_path / "plant.npz", A=A, B=B, C=C, D=np.array(D))
    path = _write(tmp_path / "s", {"kind": "state_space", "file": "../plant.npz"})
    with pytest.raises(OutsideTable, match="state-space files are read from the session's folder"):
        load_session(path)
    session = load_session(path, allow_outside_tables=True)
    condition = session.problem.conditions[0]
    response = open_loop(condition.network, "e", W, session.problem.condition_values(0), sensitivities=False).value
    assert np.allclose(response, PLANT(1j * W).ravel(), rtol=1e-13)


def test_new_keeps_a_high_order_state_space_as_a_block(tmp_path, capsys):
    """Order 60, modes from 0.01 to 1000 rad/s: its polynomial's coefficients overflow, so the
    import multiplied out (scipy's ss2tf) was refused; the block is imported as it is."""
    rng = np.random.default_rng(60)
    w, zeta = np.geomspace(1e-2, 1e3, 30), rng.uniform(0.001, 0.05, 30)
    blocks = [np.array([[-z * x, x], [-x, -z * x]]) for x, z in zip(w, zeta)]
    big_a = np.zeros((60, 60))
    for k, b in enumerate(blocks):
        big_a[2 * k : 2 * k + 2, 2 * k : 2 * k + 2] = b
    q = np.linalg.qr(rng.standard_normal((60, 60)))[0]
    a, b, c = q @ big_a @ q.T, rng.standard_normal((60, 1)), rng.standard_normal((1, 60))
    np.savez(tmp_path / "big.npz", A=a, B=b, C=c)
    assert (
        main(["new", "--plant-file", str(tmp_path / "big.npz"), "--compensator", "gain", str(tmp_path / "s.json")]) == 0
    )
    session = load_session(tmp_path / "s.json")
    transfer = session.model.problem.conditions[0].plant.blocks[1].transfer
    assert transfer.kind == "state_space" and len(transfer.A) == 60
    assert session.model.problem.grid.start <= 1e-4 and session.model.problem.grid.stop >= 1e5  # beyond its modes
    w = np.geomspace(1e-2, 1e3, 7)
    assert np.allclose(_plant_response(tmp_path / "s.json", w), control.ss(a, b, c, 0)(1j * w).ravel(), rtol=1e-9)


def test_analyze_ss_prints_the_margins_of_the_state_space_loop(tmp_path, capsys):
    np.savez(tmp_path / "plant.npz", A=A, B=B, C=C, D=np.array(D))
    assert main(["analyze", "--ss", str(tmp_path / "plant.npz"), "--tf", "2", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    gm, pm, _, wg, wp, _ = control.stability_margins(2 * PLANT, returnall=True)
    assert [p["frequency"] for p in data["phase_margins"]] == pytest.approx(list(wp), rel=1e-9)
    assert [p["phase_deg"] for p in data["phase_margins"]] == pytest.approx(list(pm), rel=1e-9)
    poles = np.sort_complex([complex(p["real"], p["imag"]) for p in data["closed_loop_poles"]])
    assert np.allclose(poles, np.sort_complex(control.feedback(2 * PLANT, 1).poles()), rtol=1e-12)
    assert main(["analyze", "--ss", str(tmp_path / "plant.npz")]) == 0
    assert "state space" in capsys.readouterr().out


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda d: (d / "p.json").write_text('{"A": [[1]], "B": [1], "C": [1, 2]}'), "C is 2; with A 1 x 1"),
        (lambda d: (d / "p.json").write_text('{"A": [[1]], "B": [1], "C": [1], "D": NaN}'), "not JSON"),
        (lambda d: (d / "p.npz").write_bytes(b"not a zip archive"), "cannot read"),
        (lambda d: None, "cannot read"),
    ],
)
def test_analyze_ss_refuses_bad_files_with_status_2_and_one_line(tmp_path, capsys, make, message):
    make(tmp_path)
    name = "p.json" if "JSON" in message or "C is" in message else "p.npz"
    assert main(["analyze", "--ss", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err
    assert message in err and name in err and err.count("\n") == 1 and "Traceback" not in err


def test_the_one_line_form_replaces_a_state_space_whole():
    inline = parse_transfer("state_space: inline", "s", current=_model(INLINE))
    assert inline.A == INLINE["A"] and format_transfer(inline) == "state_space: inline"
    from_file = parse_transfer("state_space: plant.npz", "s")
    assert from_file.file == "plant.npz" and format_transfer(from_file) == "state_space: plant.npz"
    with pytest.raises(FormError, match="keeps its matrices"):
        parse_transfer("state_space: inline", "s", current=from_file)
    with pytest.raises(FormError, match="a .npz or .json file"):
        parse_transfer("state_space:", "s")


def _model(transfer: dict):
    from sessions.format.schema import StateSpaceBlock

    return StateSpaceBlock.model_validate(transfer)


def test_the_plant_tab_shows_order_poles_and_zeros_in_one_line(tmp_path):
    session = load_session(_write(tmp_path, INLINE))
    rows = {cells[1]: cells for cells, _ in plant_rows(session.model.problem, session.problem)}
    line = rows["plant"][5]  # G = (0.5 s^2 + 2.35 s + 5)/(s^2 + 0.7 s + 4)
    assert (
        rows["plant"][4] == "state_space" and line == "state space, order 2: poles -0.35+-1.969j, zeros -2.35+-2.116j"
    )
    transfer = session.problem.conditions[0].network.entries[1].transfer
    assert describe_state_space(transfer) == line
    assert plant_rows(session.model.problem)[1][0][5] == "inline"  # without the built problem: the model's text


def test_a_cascade_s_actuator_as_state_space_takes_the_transducer_gain(tmp_path):
    data = new_session(INLINE, "gain")
    data["problem"]["conditions"][0]["plant"] = {
        "format": "cascade",
        "g1": {"kind": "expression", "expression": "1/(s + 1)"},
        "g2": {"kind": "expression", "expression": "1/s"},
        "ga": INLINE,
        "transducer_gain": 2.0,
        "h1": {"kind": "expression", "expression": "K"},
    }
    (tmp_path / "s.json").write_text(json.dumps(data))
    network = load_session(tmp_path / "s.json").problem.conditions[0].network
    ga = next(e.transfer for e in network.entries if e.label == "Ga")
    assert np.allclose(ga.evaluate(1j * W, {}).value, 2 * PLANT(1j * W).ravel(), rtol=1e-13)


def test_the_plant_tab_s_row_replaces_a_state_space_whole(tmp_path):
    from tui.state.edits import plant_edit
    from tui.state.workbench import Workbench

    bench = Workbench(load_session(_write(tmp_path, INLINE)))
    ref = next(ref for cells, ref in plant_rows(bench.session.model.problem) if cells[1] == "plant")
    edit = plant_edit(bench, ref)
    assert edit.text == "plant u y state_space: inline" and edit.check(edit.text) is None
    before = bench.session.model.problem.model_dump()
    edit.apply(edit.text)
    assert bench.session.model.problem.model_dump() == before
    np.savez(tmp_path / "half.npz", A=A, B=B, C=C / 2, D=np.array(D / 2))
    plant_edit(bench, ref).apply("plant u y state_space: half.npz")
    assert bench.session.model.problem.conditions[0].plant.blocks[ref[-1]].transfer.file == "half.npz"
    condition = bench.session.problem.conditions[0]
    response = open_loop(condition.network, "e", W, bench.session.problem.condition_values(0), sensitivities=False)
    assert np.allclose(response.value, PLANT(1j * W).ravel() / 2, rtol=1e-13)
    with pytest.raises(SessionError, match="missing.npz"):
        plant_edit(bench, ref).apply("plant u y state_space: missing.npz")

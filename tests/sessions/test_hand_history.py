"""The earlier stages of a session (issue 38, section 3): values alone changed is a hand
move, joined to the one just before it and dropped where it comes back to where it
was; any other edit drops the earlier stages, which would not replay on the problem as
it is now."""

from __future__ import annotations

from sessions.hand_history import earlier_lines, note_edit
from sessions.store import load_session


def _lead(tmp_path, monkeypatch):
    from tui.cli import main

    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    return load_session(path)


def _set(session, name: str, value: float) -> None:
    before = session.model.problem.model_copy(deep=True)
    next(p for p in session.model.problem.parameters if p.name == name).value = value
    note_edit(session, before)


def test_hand_moves_join_and_a_move_back_leaves_no_change(tmp_path, monkeypatch):
    session = _lead(tmp_path, monkeypatch)
    k = next(p.value for p in session.model.problem.parameters if p.name == "K")
    _set(session, "K", 2 * k)
    _set(session, "T1", 3.0)
    (stage,) = session.model.earlier
    assert {c.name: (c.before, c.after) for c in stage.changes}["K"] == (k, 2 * k)
    assert earlier_lines(session)[0].startswith("hand: K: ")
    _set(session, "K", k)  # K back where it was: only T1's change is left
    assert [c.name for c in session.model.earlier[0].changes] == ["T1"]


def test_an_edit_of_anything_but_values_drops_the_earlier_stages(tmp_path, monkeypatch):
    session = _lead(tmp_path, monkeypatch)
    _set(session, "T1", 3.0)
    before = session.model.problem.model_copy(deep=True)
    next(p for p in session.model.problem.parameters if p.name == "T1").max = 50.0
    note_edit(session, before)
    assert session.model.earlier == [] and earlier_lines(session) == []

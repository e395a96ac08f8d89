"""The stepper protocol by construction: every installed algorithm is found through
its entry point; binding gives a frozen stepper; a saved run resumes from its stored
state (State.from_json and step, never a re-init) and replays; iteration 0's record
is made by one function."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from engine.errors import EngineError
from engine.stepping.driver import first_record, iterate, resume
from engine.stepping.protocol import State
from engine.stepping.registry import GROUP, known, lookup, make_settings, registrations
from sessions.store import load_session

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "sessions" / "examples"
SESSIONS = {
    "cip": "report003_lag_lead.json",
    "slp": "coebra_lag_lead.json",
    "qcg": "seidel_inlet_pi.json",
    "projection": "projection_integrator.json",
}


def bound(name: str):
    session = load_session(EXAMPLES / SESSIONS[name])
    return lookup(name).bind(session.problem, make_settings(name, session.model.algorithm.settings))


def test_every_algorithm_is_found_through_its_entry_point():
    assert {"cip", "qcg", "slp", "projection", "compass", "gradient"} <= set(known())
    for name, registration in registrations().items():
        assert registration.name == name and registration.memory_type is not None
    with pytest.raises(EngineError, match=r"unknown algorithm 'newton' \(known: cip, .*slp\)"):
        lookup("newton")
    assert GROUP == "loopcraft.algorithms"


@pytest.mark.parametrize("name", sorted(SESSIONS))
def test_a_bound_stepper_is_frozen(name):
    stepper = bound(name)
    with pytest.raises(AttributeError, match="a bound stepper does not change"):
        stepper.problem = None
    state = stepper.init()
    before = dict(vars(stepper))
    stepper.step(state)
    assert {k: id(v) for k, v in vars(stepper).items()} == {k: id(v) for k, v in before.items()}


@pytest.mark.parametrize("name", sorted(SESSIONS))
def test_a_stored_run_resumes_by_from_json_and_step(name):
    """Two steps, the state stored as JSON, a new stepper: resuming from the stored state
    gives the same records as running on (no re-init in between)."""
    straight = [r.to_json() for _, r in iterate(bound(name), max_iter=4)]
    first = iterate(bound(name), max_iter=2)
    head = [r.to_json() for _, r in first]
    stored = json.loads(json.dumps(first.state.to_json()))
    fresh = bound(name)
    state = resume(fresh, stored, 2)
    assert isinstance(state, State) and state.to_json() == first.state.to_json()
    tail = [r.to_json() for _, r in iterate(fresh, max_iter=2, state=state)]
    assert head + tail == straight[: len(head + tail)]


def test_resume_without_a_stored_state_steps_again_from_the_start():
    made = list(iterate(bound("slp"), max_iter=3))
    again = resume(bound("slp"), None, len(made))
    assert len(made) == 3 and again.to_json() == made[-1][0].to_json()


def test_iteration_zero_is_the_presenters():
    stepper = bound("cip")
    record = first_record(lookup("cip").presenter, stepper)
    assert record is not None and record.iteration == 0 and record.measures


ALGORITHM_NAMES = {"cip", "qcg", "slp", "projection"}


def literal_names(folder: Path) -> list[str]:
    """Every string constant in a folder's code that is exactly an algorithm's name."""
    found = []
    for path in folder.rglob("*.py"):
        if "examples" in path.parts:  # the scripts that write the bundled sessions name their algorithm
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and node.value in ALGORITHM_NAMES:
                found.append(f"{path.relative_to(folder)}:{node.lineno}: {node.value!r}")
    return found


def test_no_algorithm_name_is_a_literal_in_sessions_or_tui():
    assert literal_names(ROOT / "sessions") == [] and literal_names(ROOT / "tui") == []


def test_the_literal_check_finds_one(tmp_path):
    (tmp_path / "x.py").write_text('ALGORITHM = "cip"\n')
    assert literal_names(tmp_path) == ["x.py:1: 'cip'"]


def test_an_algorithms_settings_types_are_resolved_once(monkeypatch):
    """Every edit of a problem binds its algorithm again (`make_settings`): the settings
    class's annotations are resolved once, not on every bind (about 0.9 ms of a nudge), and
    each bind still checks the values against them."""
    import typing

    resolved, hints = [], typing.get_type_hints
    monkeypatch.setattr(typing, "get_type_hints", lambda cls, *a, **k: resolved.append(cls) or hints(cls, *a, **k))
    settings = lookup("slp").settings
    for _ in range(3):
        make_settings("slp", {})
    assert resolved.count(settings) <= 1
    with pytest.raises(EngineError, match="initial_step"):
        make_settings("slp", {"initial_step": "big"})

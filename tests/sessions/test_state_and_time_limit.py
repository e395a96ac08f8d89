"""A stored state is checked when a session loads; a run's wall-clock limit is the
driver's, so a time-limited run replays and resumes."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from sessions.errors import SessionError
from sessions.runner import replay, run_session
from sessions.store import load_session, save_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def test_a_corrupt_stored_state_is_rejected_at_load_naming_the_field(matching):
    session = load_session(matching)
    run_session(session, iterations=2, autosave=False)
    save_session(session)
    assert load_session(matching).state.to_json() == session.model.state
    data = json.loads(matching.read_text())
    data["state"]["memory"]["step"] = "big"
    matching.write_text(json.dumps(data))
    with pytest.raises(
        SessionError, match=r"state: gradient memory\.step: expected a finite number, got the string \"big\""
    ):
        load_session(matching)


def test_an_slp_run_with_a_time_limit_replays_and_resumes(tmp_path):
    path = shutil.copy2(EXAMPLES / "coebra_lag_lead.json", tmp_path / "lag_lead.json")
    session = load_session(path)
    made = run_session(session, until_done=True, autosave=False, time_limit=0.0)
    assert made.stopped == "time limit" and len(made) == 1 and not made[-1].status.finished
    save_session(session)
    assert replay(load_session(path)).ok
    again = load_session(path)
    rest = run_session(again, until_done=True, autosave=False)
    assert rest.stopped is None and rest[-1].status.finished
    save_session(again)
    result = replay(load_session(path))
    assert result.ok and result.iterations == 1 + len(rest)


def test_slp_time_limit_setting_is_refused_with_the_way_to_the_run_option(tmp_path):
    path = shutil.copy2(EXAMPLES / "coebra_lag_lead.json", tmp_path / "lag_lead.json")
    data = json.loads(Path(path).read_text())
    data["algorithm"]["settings"]["time_limit"] = 60
    Path(path).write_text(json.dumps(data))
    with pytest.raises(SessionError, match="'time_limit' is no longer a setting.*--time-limit SECONDS"):
        run_session(load_session(path), autosave=False)

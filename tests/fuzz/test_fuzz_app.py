"""Fuzz the workbench (`tests.fuzz.app_fuzz`): mutated bundled examples opened in the
app under Textual's pilot, random keys and typed dialog text; the app must never die
and the session file on disk must never be corrupted or lost.

`make test` runs LOOPCRAFT_FUZZ_APP_CASES (default 3, about 15 s) cases; `make fuzz`
runs 200.  A failure prints its seed, case number and keys."""

from __future__ import annotations

import pytest

from tests.fuzz.app_fuzz import draw_app_case, run_case
from tests.fuzz.campaign import DEFAULT_SEED, setting

CASES = int(setting("APP_CASES", 3))
SEED = int(setting("SEED", DEFAULT_SEED))


def test_fuzzed_sessions_and_keys_never_kill_the_app_or_the_file(tmp_path):
    failures = []
    for index in range(CASES):
        case = draw_app_case(SEED, index)
        failure = run_case(case, tmp_path / f"case{index}")
        if failure is not None:
            failures.append(f"{case.describe()}\n  {failure}")
    if failures:
        pytest.fail(f"{len(failures)} of {CASES} app case(s) failed:\n" + "\n".join(failures), pytrace=False)


def test_the_app_fuzzer_sees_a_death_and_a_lost_file(tmp_path, monkeypatch):
    """An exception escaping an action is reported; so is a session file removed."""
    from tui.app import LoopcraftApp

    def dies(self):
        raise KeyError("boom")

    case = draw_app_case(SEED, 0)
    case.keys, case.texts = ["s"], [""]
    monkeypatch.setattr(LoopcraftApp, "action_step", dies)
    assert "KeyError" in (run_case(case, tmp_path / "dies") or "")
    monkeypatch.undo()
    monkeypatch.setattr(LoopcraftApp, "action_step", lambda self: self.bench.session.path.unlink())
    assert "gone" in (run_case(case, tmp_path / "lost") or "")

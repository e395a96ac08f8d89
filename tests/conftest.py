"""Hypothesis runs derandomized in `make test` (the same examples on every
machine, so CI is repeatable); `HYPOTHESIS_PROFILE=explore make test` draws
new examples each run to look for more."""

import os

from hypothesis import settings

settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent
FOLDER_MARKS = {"tui": "app", "fuzz": "fuzz", "bench": "bench"}


def pytest_collection_modifyitems(config, items):
    """Tests of the Textual app and fuzzers are marked by their folder (pyproject.toml's
    markers; `make test-fast` leaves them out with the ones marked slow)."""
    for item in items:
        folder = item.path.relative_to(TESTS).parts[0]
        if folder in FOLDER_MARKS:
            item.add_marker(FOLDER_MARKS[folder])


@pytest.fixture(autouse=True)
def _no_user_config(tmp_path, monkeypatch):
    """No test reads the user's own config file (tui.config)."""
    monkeypatch.setenv("LOOPCRAFT_CONFIG", str(tmp_path / "no-config.toml"))


@pytest.fixture(scope="module")
def ran_lag_lead(tmp_path_factory) -> Path:
    """coebra_lag_lead after four slp iterations, saved in a folder of its own (the design
    reports' session)."""
    import shutil

    from sessions.runner import run_session
    from sessions.store import load_session, save_session

    folder = tmp_path_factory.mktemp("report")
    path = folder / "lag_lead.json"
    shutil.copy(Path(__file__).resolve().parents[1] / "sessions" / "examples" / "coebra_lag_lead.json", path)
    session = load_session(path)
    run_session(session, iterations=4, autosave=False)
    save_session(session, path)
    return path

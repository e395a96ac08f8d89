"""Hypothesis runs derandomized in `make test` (the same examples on every
machine, so CI is repeatable); `HYPOTHESIS_PROFILE=explore make test` draws
new examples each run to look for more."""

import os

from hypothesis import settings

settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

import pytest


@pytest.fixture(autouse=True)
def _no_user_config(tmp_path, monkeypatch):
    """No test reads the user's own config file (tui.config)."""
    monkeypatch.setenv("LOOPCRAFT_CONFIG", str(tmp_path / "no-config.toml"))

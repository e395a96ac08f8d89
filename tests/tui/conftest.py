"""The app under test: its own LOOPCRAFT_HOME and working copies of the examples."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


@pytest.fixture
def workdir(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    for f in EXAMPLES.iterdir():
        if f.suffix in (".json", ".csv"):
            shutil.copy2(f, tmp_path / f.name)
    return tmp_path

"""Files a user names are read one way (`sessions.format.reading`): a session, its
autosave and a CSV table are regular files within a bound (a symlink to /dev/zero,
a FIFO, a folder, a symlink loop: refused at once, by name), UTF-8 with or
without a BOM; one table-row limit, the engine's."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from engine.model import blocks
from sessions.build import read_csv
from sessions.errors import SessionError
from sessions.format import limits
from sessions.format.reading import read_regular
from sessions.store import load_session
from tests.sessions.test_table_paths import COLUMNS, INLET, _session
from tui.cli import main

NOT_REGULAR = ("dev_zero", "fifo", "folder", "loop")


def _not_regular(path: Path, kind: str) -> Path:
    if kind == "dev_zero":
        os.symlink("/dev/zero", path)
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    else:
        os.symlink(path.name, path)  # a symlink to itself
    return path


@pytest.mark.parametrize("kind", NOT_REGULAR)
def test_a_session_that_is_not_a_regular_file_is_refused_at_once(tmp_path, kind, capsys):
    path = _not_regular(tmp_path / "s.json", kind)
    with pytest.raises(SessionError, match="s.json"):
        load_session(path)
    assert main(["report", str(path)]) == 2
    err = capsys.readouterr().err
    assert "s.json" in err and "Traceback" not in err


@pytest.mark.parametrize("kind", NOT_REGULAR)
def test_a_table_that_is_not_a_regular_file_is_refused_naming_its_json_path(matching_dict, tmp_path, kind):
    folder = tmp_path / "s"
    folder.mkdir()
    _not_regular(folder / "t.csv", kind)
    with pytest.raises(SessionError, match=r"problem\.conditions\[0\].*\.csv: .*t\.csv"):
        load_session(_session(matching_dict, folder, "t.csv"))


def test_a_symlink_loop_says_so(matching_dict, tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    _not_regular(folder / "t.csv", "loop")
    with pytest.raises(SessionError, match="symlink loop|Too many levels of symbolic links"):
        load_session(_session(matching_dict, folder, "t.csv"))


def test_a_session_file_is_read_with_a_bound(tmp_path, monkeypatch):
    path = tmp_path / "big.json"
    path.write_text(" " * 200)
    with pytest.raises(SessionError, match="at most 100"):
        read_regular(path, 100)
    monkeypatch.setattr(limits, "MAX_SESSION_BYTES", 100)
    from sessions import store

    monkeypatch.setattr(store, "MAX_SESSION_BYTES", 100)
    with pytest.raises(SessionError, match="big.json has 200 bytes; at most 100"):
        load_session(path)


def test_a_bom_is_read_in_sessions_and_tables(matching_dict, tmp_path):
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "t.csv").write_bytes(b"\xef\xbb\xbf" + INLET.read_bytes())
    assert read_csv(folder / "t.csv", COLUMNS, "table")[0]
    path = _session(matching_dict, folder, "t.csv")
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert load_session(path).problem.conditions


def test_one_table_row_limit(tmp_path):
    assert limits.MAX_TABLE_ROWS == blocks.MAX_TABLE_ROWS
    docs = (Path(__file__).resolve().parents[2] / "docs" / "session-format.md").read_text()
    row = next(line for line in docs.splitlines() if line.startswith("| rows of an inline table"))
    assert f"{blocks.MAX_TABLE_ROWS:,}".replace(",", " ") in row
    shutil.copy(INLET, tmp_path / "t.csv")
    doc = {"unit": "hz", "frequency": [1.0] * (blocks.MAX_TABLE_ROWS + 1)}
    from pydantic import ValidationError

    from sessions.format.schema import TableModel

    with pytest.raises(ValidationError):
        TableModel.model_validate(json.loads(json.dumps(doc)))

"""Why a save is refused says what is really wrong and offers what the command has:
a read-only file system is EROFS (force cannot help; the mode bits are writable),
a read-only file is its mode; `run` has no force and says to save elsewhere
with --out ("read-only (mode 0644) ... save with force" on a read-only mount)."""

from __future__ import annotations

import os

import pytest

from sessions import store
from sessions.errors import SessionError
from sessions.format import save_file
from sessions.store import load_session, save_session
from tui.cli import main


@pytest.fixture
def read_only_mount(monkeypatch):
    """statvfs says read-only and access refuses writing, as on a read-only mount."""
    real = os.statvfs

    class Flags:
        def __init__(self, path):
            self.f_flag = real(path).f_flag | os.ST_RDONLY

    monkeypatch.setattr(save_file.os, "statvfs", Flags)
    monkeypatch.setattr(save_file.os, "access", lambda path, mode: False)


def test_a_read_only_file_system_is_named_and_force_is_not_offered(matching, read_only_mount, capsys):
    session = load_session(matching)
    with pytest.raises(SessionError, match=r"file system is read-only \(EROFS\)") as refused:
        save_session(session, force=True)
    assert not isinstance(refused.value, store.OverwriteRefused) and "mode" not in str(refused.value)
    assert main(["run", str(matching)]) == 2
    err = capsys.readouterr().err
    assert "EROFS" in err and "force" not in err and "mode 0" not in err


def test_run_on_a_read_only_file_offers_out_not_force(matching, capsys):
    matching.chmod(0o444)
    assert main(["run", str(matching)]) == 2
    err = capsys.readouterr().err
    assert "read-only (mode 0444)" in err and "--out FILE" in err and "save with force" not in err

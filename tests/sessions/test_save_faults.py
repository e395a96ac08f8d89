"""Saving under faults: non-finite numbers, deep nesting, a read-only folder,
a full disk, two processes on one file, a symlink, file modes.  In every case
the old file is intact and the message is one clear line."""

from __future__ import annotations

import errno
import json
import os
import shutil
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sessions import store
from sessions.errors import SessionError
from sessions.runner import run_session
from sessions.store import autosave_path, load_session, save_session, write_autosave
from tests.sessions.conftest import MATCHING
from tests.sessions.test_malformed import PATHS, _mutate
from tui.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "sessions" / "examples"


def _temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith("tmp"))


# -- non-finite numbers ---------------------------------------------------------


def test_an_infinite_bound_saves_and_reads_back(matching_dict, tmp_path):
    matching_dict["problem"]["parameters"][1].update(min=-12345.5, max=12345.5)
    path = tmp_path / "inf.json"
    path.write_text(json.dumps(matching_dict, indent=2).replace("-12345.5", "-1e999").replace("12345.5", "1e999"))
    try:
        session = load_session(path)
    except SessionError as exc:  # refused where it makes no sense (the schema's choice) ...
        assert str(exc).startswith(f"{path}: problem.parameters[1].m")
        return
    assert session.model.problem.parameters[1].max == float("inf")
    save_session(session)  # ... or saved: never "Out of range float values are not JSON compliant"
    again = load_session(path).model.problem.parameters[1]
    assert (again.min, again.max) == (float("-inf"), float("inf"))
    assert json.loads(path.read_text())["problem"]["parameters"][1]["max"] == float("inf")  # standard JSON


def test_non_finite_values_in_free_form_data_save(matching_dict, tmp_path):
    matching_dict["problem"]["objective"]["data"] = {"big": 1.5, "none": 2.5}
    record = {
        "iteration": 1,
        "status": "running",
        "parameters": {"K": 1.0, "T": 0.1},
        "measures": [
            {
                "name": "P1",
                "kind": "phase_margin_deg",
                "condition": "nominal",
                "value": 3.5,
                "desired": 45.0,
                "satisfied": False,
                "frequency": 4.5,
            }
        ],
    }
    matching_dict.update(records=[record], current_iteration=1)
    path = tmp_path / "nan.json"
    path.write_text(
        json.dumps(matching_dict)
        .replace("1.5", "1e999")
        .replace("2.5", "NaN")
        .replace("3.5", "-Infinity")
        .replace("4.5", "NaN")
    )
    session = load_session(path)
    save_session(session)
    again = load_session(path)
    assert again.model.problem.objective.data["big"] == float("inf")
    row = again.records[0].measures[0]
    assert row.value == float("-inf") and row.frequency != row.frequency


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**6), 10**6) | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=6,
)


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(mutant=st.tuples(st.sampled_from(PATHS), st.sampled_from(["delete", "replace"]), JSON_VALUES))
def test_saving_never_fails_on_what_loading_accepted(tmp_path, mutant):
    path = tmp_path / "mutant.json"
    path.write_text(_mutate(MATCHING, *mutant))  # json.dumps writes inf and nan as Infinity and NaN
    try:
        session = load_session(path)
    except SessionError:
        return
    saved = save_session(session, tmp_path / "saved.json", force=True)
    try:
        load_session(saved)
    except SessionError as exc:
        assert str(exc)


# -- deep nesting --------------------------------------------------------------------


def _nest(depth: int) -> dict:
    node: dict = {}
    for _ in range(depth):
        node = {"a": node}
    return node


def _deep_objective(doc):
    doc["problem"]["objective"]["data"] = {"deep": _nest(300)}


def _deep_state(doc):
    doc["state"] = {"iteration": 0, "x": [1.0, 0.1], "status": "running", "memory": _nest(300)}


def _deep_record(doc):
    doc["records"] = [{"iteration": 1, "status": "running", "parameters": {}, "measures": [], "extra": _nest(300)}]
    doc["current_iteration"] = 1


@pytest.mark.parametrize(
    "change, where",
    [
        (_deep_objective, r"problem\.objective\.data\.deep\.a"),
        (_deep_state, r"state\.memory\.a\.a"),
        (_deep_record, r"records\[0\]\.extra\.a\.a"),
    ],
)
def test_deep_nesting_is_refused_at_load(matching_dict, tmp_path, change, where):
    change(matching_dict)
    path = tmp_path / "deep.json"
    path.write_text(json.dumps(matching_dict))
    with pytest.raises(SessionError, match=rf"^{path}: {where}.*: nested more than 64 levels deep"):
        load_session(path)


# -- a read-only folder (simulated: the tests run as root, who may write anywhere) -----


@pytest.fixture
def read_only(monkeypatch):
    """Make folders refuse new files, renames into them and deletions, as a read-only one does."""
    folders: list[Path] = []
    real_open, real_replace, real_unlink = os.open, os.replace, os.unlink

    def inside(path) -> bool:
        return Path(path).parent.resolve() in folders

    def fake_open(path, flags, mode=0o777, *, dir_fd=None):
        if flags & os.O_CREAT and inside(path):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, mode, dir_fd=dir_fd)

    def fake_replace(src, dst, **kw):
        if inside(dst):
            raise PermissionError(errno.EACCES, "Permission denied", str(dst))
        return real_replace(src, dst, **kw)

    def fake_unlink(path, **kw):
        if inside(path) and os.path.lexists(path):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_unlink(path, **kw)

    monkeypatch.setattr(os, "open", fake_open)
    monkeypatch.setattr(os, "replace", fake_replace)
    monkeypatch.setattr(os, "unlink", fake_unlink)
    return lambda folder: folders.append(Path(folder).resolve())


@pytest.fixture
def locked(matching, read_only):
    folder = matching.parent / "locked"
    folder.mkdir()
    path = folder / "matching.json"
    shutil.copy2(matching, path)
    read_only(folder)
    return path


def test_run_out_of_a_read_only_folder_saves_elsewhere(locked, tmp_path, capsys):
    out = tmp_path / "out" / "result.json"
    out.parent.mkdir()
    before = sorted(os.listdir(locked.parent))
    assert main(["run", str(locked), "--iterations", "2", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["current_iteration"] == 2
    assert sorted(os.listdir(locked.parent)) == before
    assert "Traceback" not in capsys.readouterr().err


def test_run_in_a_read_only_folder_fails_before_the_work(locked, capsys, monkeypatch):
    before = locked.read_bytes()

    def no_work(*args, **kwargs):
        raise AssertionError("the run started before the output was found unwritable")

    monkeypatch.setattr("sessions.runner.run_session", no_work)
    assert main(["run", str(locked), "--iterations", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{locked}: cannot save: the folder {locked.parent} is not writable" in err[0]
    assert "EACCES" in err[0] and locked.read_bytes() == before


def test_an_autosave_that_cannot_be_written_is_a_warning(locked):
    session = load_session(locked)
    records = run_session(session, iterations=2)  # autosaves on the way: never raises
    assert len(records) == 2 and not autosave_path(locked).exists()
    assert session.autosave_warning.startswith(f"{autosave_path(locked)}: cannot autosave: Permission denied")
    with pytest.raises(SessionError, match=r"cannot save: Permission denied \(EACCES\)"):
        save_session(session)
    assert load_session(locked).model.current_iteration == 0


# -- a full disk -----------------------------------------------------------------------


def test_a_full_disk_is_a_clean_error_and_the_old_file_stays(matching, monkeypatch):
    session = load_session(matching)
    run_session(session, iterations=1, autosave=False)
    save_session(session)
    before = matching.read_bytes()
    run_session(session, iterations=1, autosave=False)

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(SessionError, match=rf"^{matching}: cannot save: No space left on device \(ENOSPC\)$"):
        save_session(session)
    assert write_autosave(session) is None
    assert "cannot autosave: No space left on device (ENOSPC)" in session.autosave_warning
    assert matching.read_bytes() == before and not autosave_path(matching).exists()
    assert _temporaries(matching.parent) == []
    monkeypatch.undo()
    save_session(session)
    assert load_session(matching).model.current_iteration == 2 and session.autosave_warning is None


# -- two processes on one file ---------------------------------------------------------


def test_a_save_sweeps_only_old_temporary_files(matching):
    in_flight = [
        matching.parent / f".{matching.name}.inflight.tmp",
        matching.parent / f".{matching.name}.autosave.inflight.tmp",
    ]
    stale = matching.parent / f".{matching.name}.left.tmp"
    for p in in_flight + [stale]:
        p.write_text("{")
    hours_ago = time.time() - 2 * 3600
    os.utime(stale, (hours_ago, hours_ago))
    save_session(load_session(matching))
    assert _temporaries(matching.parent) == sorted(p.name for p in in_flight)


def test_a_file_changed_on_disk_is_not_overwritten_without_force(matching):
    first, second = load_session(matching), load_session(matching)
    first.model.notes = "first"
    save_session(first)
    second.model.notes = "second"
    with pytest.raises(store.OverwriteRefused, match=rf"^{matching}: changed on disk since it was loaded"):
        save_session(second)
    assert load_session(matching).model.notes == "first"
    save_session(second, force=True)
    assert load_session(matching).model.notes == "second"
    save_session(second)  # its own save is not a change on disk
    third = load_session(matching)
    later = time.time() + 5
    os.utime(matching, (later, later))  # touched, not changed
    save_session(third)


SAVER = r"""
import sys
from sessions.store import load_session, save_session
session = load_session(sys.argv[1])
for i in range(int(sys.argv[2])):
    session.model.notes = sys.argv[3] * (1 + i % 7) * 20_000
    save_session(session, force=True)
"""


@pytest.mark.slow
def test_two_processes_saving_one_file_never_break_each_other(matching):
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", SAVER, str(matching), "150", mark],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for mark in "ab"
    ]
    outcomes = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [err for _, err in outcomes]
    assert set(load_session(matching).model.notes) in ({"a"}, {"b"})
    assert _temporaries(matching.parent) == []


# -- a symlink -------------------------------------------------------------------------


def test_a_symlinked_session_saves_through_the_link_and_reads_tables_beside_the_real_file(tmp_path):
    real = tmp_path / "real"
    real.mkdir()
    for name in ("cip_launch_vehicle.json", "cip_launch_vehicle.csv"):
        shutil.copy2(EXAMPLES / name, real / name)
    (tmp_path / "links").mkdir()
    link = tmp_path / "links" / "session.json"
    link.symlink_to(Path("..") / "real" / "cip_launch_vehicle.json")
    session = load_session(link)  # the CSV is beside the real file
    session.model.notes = "through the link"
    save_session(session)
    assert link.is_symlink() and load_session(real / "cip_launch_vehicle.json").model.notes == "through the link"
    assert (real / "cip_launch_vehicle.json.bak").exists() and os.listdir(tmp_path / "links") == ["session.json"]
    assert write_autosave(session) == real / "cip_launch_vehicle.json.autosave"
    assert store.autosave_candidate(link) == real / "cip_launch_vehicle.json.autosave"
    save_session(session, real / "copy.json")  # beside the real file: the table names stay as they are
    assert load_session(real / "copy.json").model.problem == session.model.problem


def test_a_recovered_autosave_saves_over_its_file_unless_that_changed(matching):
    session = load_session(matching)
    run_session(session, iterations=2)  # autosaved, not saved
    recovered = store.load_autosave(matching)
    assert recovered.path == matching and recovered.model.current_iteration == 2
    other = load_session(matching)
    other.model.notes = "saved meanwhile"
    save_session(other)
    with pytest.raises(store.OverwriteRefused, match="changed on disk since it was loaded"):
        save_session(recovered)
    save_session(recovered, force=True)
    assert load_session(matching).model.current_iteration == 2 and not autosave_path(matching).exists()


def test_a_target_that_is_not_a_file_is_refused(matching, tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    session = load_session(matching)
    for target in (fifo, tmp_path):
        with pytest.raises(SessionError, match=rf"^{target}: cannot save: (not a file|it is a folder)$"):
            save_session(session, target, force=True)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    with pytest.raises(SessionError, match=r"cannot save: the folder .*missing.* does not exist"):
        store.prepare_save(session, tmp_path / "missing" / "out.json")


# -- file modes ------------------------------------------------------------------------


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_saving_keeps_the_file_mode_and_the_backup_has_it_too(matching, tmp_path):
    matching.chmod(0o640)
    session = load_session(matching)
    save_session(session)
    save_session(session)
    assert _mode(matching) == 0o640 and _mode(matching.with_name(matching.name + ".bak")) == 0o640
    mask = os.umask(0o022)
    os.umask(mask)
    assert _mode(save_session(session, tmp_path / "new.json")) == 0o666 & ~mask


def test_a_read_only_file_is_overwritten_only_with_force(matching, capsys):
    matching.chmod(0o444)
    session = load_session(matching)
    session.model.notes = "changed"
    before = matching.read_bytes()
    with pytest.raises(store.OverwriteRefused, match=rf"^{matching}: the file is read-only \(mode 0444\)"):
        save_session(session)
    assert matching.read_bytes() == before
    assert main(["run", str(matching)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "read-only" in err[0] and matching.read_bytes() == before
    save_session(session, force=True)
    assert load_session(matching).model.notes == "changed" and _mode(matching) == 0o444

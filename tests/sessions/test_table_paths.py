"""What a session may read: its CSV tables sit in its folder or below (an
absolute path, .. or a symlink leading out is refused unless allowed), are
regular files of bounded size, and an error quotes no more of a file than
the offending cell."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from sessions import build
from sessions.build import OutsideTable, build_problem, outside_tables_allowed, read_csv, table_path
from sessions.errors import SessionError
from sessions.store import load_session
from sessions.sweeps.plan import shippable
from tui.cli import main

INLET = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "seidel_inlet_table1.csv"
COLUMNS = ["hz", "g1_mag", "g1_phase_deg"]


def _session(matching_dict: dict, folder: Path, csv: str, columns: list[str] = COLUMNS) -> Path:
    """The tests' matching session with its plant a CSV table named ``csv``."""
    plant = matching_dict["problem"]["conditions"][0]["plant"]
    plant["blocks"][1]["transfer"] = {
        "kind": "table",
        "table": {"unit": "hz", "gain": 0.016, "csv": csv, "columns": columns},
    }
    matching_dict["problem"]["grid"] = {"unit": "hz", "start": 1.0, "stop": 600.0, "points": 50}
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "session.json"
    path.write_text(json.dumps(matching_dict))
    return path


@pytest.fixture
def outside(tmp_path) -> Path:
    """The inlet table in a folder beside the session's."""
    (tmp_path / "elsewhere").mkdir()
    return Path(shutil.copy(INLET, tmp_path / "elsewhere" / "inlet.csv"))


def test_a_table_beside_or_below_the_session_is_read(matching_dict, tmp_path):
    (tmp_path / "s" / "data").mkdir(parents=True)
    shutil.copy(INLET, tmp_path / "s" / "data" / "inlet.csv")
    os.symlink(tmp_path / "s" / "data" / "inlet.csv", tmp_path / "s" / "link.csv")  # a symlink staying inside
    for name in ("data/inlet.csv", "link.csv", "data/../data/inlet.csv"):
        load_session(_session(matching_dict, tmp_path / "s", name))


@pytest.mark.parametrize("kind", ["absolute", "dotdot", "symlink"])
def test_a_table_outside_the_folder_is_refused_unless_allowed(matching_dict, tmp_path, outside, kind):
    folder = tmp_path / "s"
    folder.mkdir()
    if kind == "symlink":
        os.symlink(outside, folder / "inlet.csv")
    name = {"absolute": str(outside), "dotdot": "../elsewhere/inlet.csv", "symlink": "inlet.csv"}[kind]
    path = _session(matching_dict, folder, name)
    with pytest.raises(SessionError, match="is outside the session's folder"):
        load_session(path)
    model = load_session_model(path)
    build_problem(model.problem, folder, allow_outside_tables=True)
    with outside_tables_allowed():
        load_session(path)
    with pytest.raises(SessionError, match="outside"):
        build_problem(model.problem, folder)  # the default is refusing again


def load_session_model(path: Path):
    from sessions.format.schema import SessionModel

    return SessionModel.model_validate(json.loads(path.read_text()))


def test_etc_passwd_is_refused_and_its_lines_never_quoted(matching_dict, tmp_path):
    passwd = tmp_path / "passwd"
    passwd.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin-secret\n")
    header = ["root:x:0:0:root:/root:/bin/bash"] * 3
    path = _session(matching_dict, tmp_path / "s", str(passwd), header)
    with pytest.raises(SessionError) as refused:
        load_session(path)
    assert "daemon" not in str(refused.value)
    with pytest.raises(SessionError, match="not a number") as allowed:
        read_csv(passwd, header, "table")
    assert "nologin-secret" not in str(allowed.value) and len(str(allowed.value)) < 200


def test_dev_zero_and_a_fifo_are_not_regular_files(tmp_path):
    os.mkfifo(tmp_path / "fifo.csv")
    for file in (Path("/dev/zero"), tmp_path / "fifo.csv", tmp_path):
        with pytest.raises(SessionError, match="not a regular file"):
            read_csv(file, COLUMNS, "table")  # at once: no read until memory runs out, no blocking open


def test_tables_are_bounded_in_bytes_and_rows(tmp_path, monkeypatch):
    big = tmp_path / "big.csv"
    with big.open("wb") as fh:
        fh.truncate(build.MAX_TABLE_BYTES + 1)  # sparse: no disk used
    with pytest.raises(SessionError, match="at most"):
        read_csv(big, COLUMNS, "table")
    rows = tmp_path / "rows.csv"
    rows.write_text("hz,g1_mag,g1_phase_deg\n" + "1,1,1\n" * (build.MAX_TABLE_ROWS + 1))
    with pytest.raises(SessionError, match=f"{build.MAX_TABLE_ROWS + 1} rows"):
        read_csv(rows, COLUMNS, "table")
    monkeypatch.setattr(build, "MAX_TABLE_BYTES", 100)  # the bounded read, whatever stat says
    monkeypatch.setattr(os, "fstat", lambda fd, real=os.fstat: os.stat_result(real(fd)[:6] + (0,) + real(fd)[7:]))
    with pytest.raises(SessionError, match="more than 100 bytes"):
        read_csv(INLET, COLUMNS, "table")


def test_a_line_that_is_not_csv_is_a_clean_error(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("hz,g1_mag,g1_phase_deg\n1,2,3\n1," + "9" * 200_000 + ",3\n")  # beyond csv's field limit
    with pytest.raises(SessionError, match="line 3: not CSV"):
        read_csv(bad, COLUMNS, "table")
    bad.write_bytes(b"hz,g1_mag,g1_phase_deg\n1,\xff,3\n")
    with pytest.raises(SessionError, match="not UTF-8"):
        read_csv(bad, COLUMNS, "table")


def test_table_path_resolves_in_the_folder(tmp_path):
    assert table_path(tmp_path, "a.csv", "t") == (tmp_path / "a.csv").resolve()
    with pytest.raises(OutsideTable, match="outside") as refused:
        table_path(tmp_path, "/etc/passwd", "t")
    assert refused.value.name == "/etc/passwd"
    assert table_path(tmp_path, "/etc/passwd", "t", allow_outside=True) == Path("/etc/passwd")


def test_sweeps_do_not_ship_an_outside_table(matching_dict, tmp_path, outside):
    path = _session(matching_dict, tmp_path / "s", "../elsewhere/inlet.csv")
    with outside_tables_allowed():
        session = load_session(path)
    with pytest.raises(SessionError, match="outside"):
        shippable(session)
    assert (
        shippable(session, allow_outside_tables=True)["problem"]["conditions"][0]["plant"]["blocks"][1]["transfer"][
            "table"
        ]["csv"]
        is None
    )


@pytest.mark.parametrize("command", [["report"], ["replay"], ["run", "--iterations", "1"]])
def test_the_cli_refuses_and_allows_with_the_option(matching_dict, tmp_path, outside, capsys, command):
    path = _session(matching_dict, tmp_path / "s", str(outside))
    assert main([command[0], str(path), *command[1:]]) == 2
    assert "is outside the session's folder" in capsys.readouterr().err
    assert main([command[0], str(path), *command[1:], "--allow-outside-tables"]) == 0


@pytest.mark.parametrize("allowed", [False, True])
def test_a_table_name_with_a_nul_character_is_a_session_error(tmp_path, allowed):
    """A fuzzed session named its table 's\\x00': pathlib raised a bare ValueError
    (a traceback from `loopcraft report`); now the JSON path and the name say why."""
    with pytest.raises(SessionError, match=r"problem\.g1\.table\.csv: 's\\x00' is not a file name"):
        table_path(tmp_path, "s\0", "problem.g1.table", allow_outside=allowed)

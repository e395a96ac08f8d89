"""Every output a command writes (`--out` of export, report, run, set, tune, sweep; `new FILE`)
goes through one check before any work: never an input of the command (the session, its
tables, by path, symlink or hard link), never a file that is not a regular one (a FIFO, a
folder), never an existing file without --force (issue 50)."""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

import pytest

from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


@pytest.fixture
def lag_lead(tmp_path: Path) -> Path:
    shutil.copy(EXAMPLES / "report003_lag_lead.json", tmp_path / "s.json")
    return tmp_path / "s.json"


@pytest.fixture
def with_table(tmp_path: Path) -> Path:
    for name in ("seidel_inlet_pi.json", "seidel_inlet_table1.csv"):
        shutil.copy(EXAMPLES / name, tmp_path / name)
    return tmp_path / "seidel_inlet_pi.json"


def _refused(capsys, argv: list[str], words: str) -> None:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1, err


@pytest.mark.parametrize(
    "command",
    [
        ["export", "{s}", "--to", "python", "--out", "{out}"],
        ["run", "{s}", "--iterations", "1", "--out", "{out}"],
        ["set", "{s}", "--out", "{out}", "z1*=1.1"],
        ["sweep", "{s}", "--starts", "2", "--serial", "--out", "{out}"],
    ],
)
def test_an_output_onto_the_session_itself_is_refused_and_the_session_kept(capsys, lag_lead, command):
    before = lag_lead.read_bytes()
    link = lag_lead.with_name("link.json")
    os.link(lag_lead, link)
    for out in (lag_lead, link):
        argv = [a.format(s=lag_lead, out=out) for a in command]
        _refused(capsys, argv, "is the session, an input of the command")
    assert lag_lead.read_bytes() == before


def test_a_csv_export_onto_the_sessions_table_is_refused(capsys, with_table):
    table = with_table.with_name("seidel_inlet_table1.csv")
    before = table.read_bytes()
    _refused(
        capsys,
        ["export", str(with_table), "--to", "csv", "--out", str(table), "--force"],
        "is the session's table seidel_inlet_table1.csv",
    )
    _refused(capsys, ["run", str(with_table), "--out", str(table), "--force"], "an input of the command")
    assert table.read_bytes() == before
    assert main(["report", str(with_table)]) == 0  # the session still loads


def test_a_fifo_or_a_folder_is_never_replaced(capsys, lag_lead, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    _refused(capsys, ["export", str(lag_lead), "--to", "json", "--out", str(fifo), "--force"], "a FIFO")
    fifo_json = tmp_path / "x.json"
    os.mkfifo(fifo_json)
    _refused(capsys, ["new", str(fifo_json), "--plant", "1/(s+1)", "--force"], "a FIFO, not a regular file")
    os.mkfifo(tmp_path / "s.html")
    _refused(capsys, ["report", str(lag_lead), "--format", "html", "--out", str(tmp_path), "--force"], "a FIFO")
    assert stat.S_ISFIFO(fifo.lstat().st_mode) and stat.S_ISFIFO(fifo_json.lstat().st_mode)
    assert stat.S_ISFIFO((tmp_path / "s.html").lstat().st_mode)


@pytest.mark.long
def test_an_existing_file_is_replaced_only_with_force(capsys, lag_lead, tmp_path):
    out = tmp_path / "design.py"
    out.write_text("keep me")
    _refused(capsys, ["export", str(lag_lead), "--to", "python", "--out", str(out)], "exists (--force replaces it)")
    assert out.read_text() == "keep me"
    assert main(["export", str(lag_lead), "--to", "python", "--out", str(out), "--force"]) == 0
    assert "import control" in out.read_text()
    report = tmp_path / "r"
    assert main(["report", str(lag_lead), "--format", "md", "--out", str(report)]) == 0
    _refused(capsys, ["report", str(lag_lead), "--format", "md", "--out", str(report)], "--force replaces it")
    assert main(["report", str(lag_lead), "--format", "md", "--out", str(report), "--force"]) == 0
    kept = tmp_path / "kept.json"
    kept.write_text("{}")
    _refused(capsys, ["run", str(lag_lead), "--out", str(kept)], "exists (--force replaces it)")
    assert kept.read_text() == "{}"


def test_commands_that_update_their_own_session_still_do(lag_lead):
    before = lag_lead.read_bytes()
    assert main(["set", str(lag_lead), "z1*=1.1"]) == 0
    assert lag_lead.read_bytes() != before

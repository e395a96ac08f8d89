"""`loopcraft export` and `loopcraft new` on the command line: files written
where asked, and bad options exit 2 with one line naming them."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "sessions" / "examples"
CMD = [sys.executable, "-m", "tui.cli"]


def run(*args, cwd=None):
    return subprocess.run(CMD + [str(a) for a in args], capture_output=True, text=True, timeout=120, cwd=cwd)


@pytest.mark.slow
def test_export_into_a_folder_names_the_file_after_the_session(tmp_path):
    shutil.copy(EXAMPLES / "report003_lag_lead.json", tmp_path / "design.json")
    for to, suffix in (("python", ".py"), ("matlab", ".m"), ("json", ".export.json"), ("csv", ".csv")):
        out = run("export", tmp_path / "design.json", "--to", to, "--out", tmp_path)
        assert out.returncode == 0, out.stderr
        assert (tmp_path / f"design{suffix}").stat().st_size > 100
    out = run("export", tmp_path / "design.json", "--to", "python", "--iteration", "0", "--out", tmp_path)
    assert (tmp_path / "design_iter0.py").is_file()


@pytest.mark.parametrize(
    "args, message",
    [
        (["--to", "python", "--iteration", "3"], "--iteration: 3 is outside 0..0"),
        (["--to", "python", "--out", "/no/such/folder/x.py"], "--out /no/such/folder/x.py: the folder"),
        (["--to", "json", "--sample-time", "-1"], "--sample-time"),
    ],
)
def test_bad_export_options_exit_2(args, message):
    out = run("export", EXAMPLES / "report003_lag_lead.json", *args)
    assert out.returncode == 2 and message in out.stderr and out.stderr.count("\n") == 1, out.stderr


def test_a_session_without_a_loop_cannot_be_exported():
    out = run("export", EXAMPLES / "projection_reactor.json", "--to", "python")
    assert out.returncode == 2 and "no flight conditions" in out.stderr


@pytest.mark.slow
def test_new_writes_a_session_that_runs(tmp_path):
    out = run("new", "--plant", "16000/(s*(s+8)*(s+20))", "--compensator", "lead-lag", tmp_path / "new.json")
    assert out.returncode == 0, out.stderr
    ran = run("run", tmp_path / "new.json", "--until-done", "--json")
    assert ran.returncode == 0, ran.stderr
    again = run("new", "--plant", "1/(s+1)", tmp_path / "new.json")
    assert again.returncode == 2 and "exists (--force replaces it)" in again.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["--plant", "1/(s+q)"], "--plant: '1/(s+q)' names q"),
        (["--plant", "1/(s+1)", "--compensator", "K*(s+"], "--compensator:"),
        ([], "give --plant EXPR or --plant-file"),
    ],
)
def test_bad_new_options_exit_2(tmp_path, args, message):
    out = run("new", *args, tmp_path / "x.json")
    assert out.returncode == 2 and message in out.stderr and out.stderr.count("\n") == 1, out.stderr
    assert not (tmp_path / "x.json").exists()

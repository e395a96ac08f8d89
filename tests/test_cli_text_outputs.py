"""Every text output survives any string a JSON file can hold (a lone surrogate
"\\ud800" in a name): the command line's text and JSON on a real pipe, the design
report's HTML and Markdown, every export; messages are bounded in length, and no
RuntimeWarning reaches the terminal of the console script."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from sessions.errors import bounded_message
from sessions.export.formats import SUFFIX
from tests.sessions.conftest import MATCHING
from tui.cli import main

LONE = "nominal\ud800"


@pytest.fixture
def surrogate_session(tmp_path) -> Path:
    doc = json.loads(json.dumps(MATCHING))
    doc["problem"]["conditions"][0]["name"] = LONE
    doc["notes"] = "notes \udfff"
    blocks = doc["problem"]["conditions"][0]["plant"]["blocks"]
    blocks[0]["transfer"]["expression"] = "K*(1+T*s)/(1+0.01*s)"  # proper: the MATLAB export refuses a PD as it is
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc))  # ASCII: the surrogate as its JSON escape
    return path


@pytest.mark.parametrize("form", ["text", "json", "csv"])
def test_report_prints_a_lone_surrogate_on_a_pipe(surrogate_session, form):
    out = subprocess.run(
        [sys.executable, "-m", "tui.cli", "report", str(surrogate_session), "--format", form],
        capture_output=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr.decode("utf-8", "replace")
    assert b"Traceback" not in out.stderr
    assert b"nominal" in out.stdout


@pytest.mark.parametrize("form", ["html", "md"])
def test_the_design_report_is_written_with_a_lone_surrogate(surrogate_session, tmp_path, form):
    assert main(["report", str(surrogate_session), "--format", form, "--out", str(tmp_path / "r")]) == 0
    written = [p for p in (tmp_path / "r").rglob("*") if p.suffix in (".html", ".md")]
    assert written and "nominal" in written[0].read_text("utf-8")


@pytest.mark.parametrize("to", sorted(SUFFIX))
def test_every_export_is_written_with_a_lone_surrogate(surrogate_session, tmp_path, to):
    assert main(["export", str(surrogate_session), "--to", to, "--out", str(tmp_path)]) == 0
    files = [p for p in tmp_path.iterdir() if p.name != "s.json"]
    assert files and all(p.read_bytes().decode("utf-8") for p in files)


def test_a_long_echoed_input_is_cut_with_its_length(tmp_path, capsys):
    doc = json.loads(json.dumps(MATCHING))
    doc["problem"]["conditions"][0]["break_at"] = "x" * 200_000
    path = tmp_path / "long.json"
    path.write_text(json.dumps(doc))
    assert main(["report", str(path)]) == 2
    err = capsys.readouterr().err
    assert "unknown signal" in err and "characters]" in err and "signals are" in err
    assert max(len(line) for line in err.splitlines()) < 400 + len(str(path))


def test_bounded_message_keeps_start_and_end():
    quoted = "'" + "x y" * 10_000 + "'"
    text = f"problem.targets[0]: {quoted} is not a name"
    shown = bounded_message(text)
    assert shown.startswith("problem.targets[0]: 'x y") and shown.endswith("' is not a name")
    assert "[30000 characters]" in shown and len(shown) < 300
    assert bounded_message("short\nlines") == "short\nlines"
    path = "/tmp/" + "d/" * 150 + "s.json"  # a long path is not an echoed input
    assert bounded_message(f"{path}: cannot save") == f"{path}: cannot save"
    assert len(bounded_message("z" * 100_000)) < 1100


def test_argparse_errors_are_cut_too(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["analyze", "--tf", "1/(s+1)", "--points", "x" * 50_000])
    assert exit_.value.code == 2
    assert max(len(line) for line in capsys.readouterr().err.splitlines()) < 400


def test_no_runtime_warning_reaches_the_console_scripts_terminal():
    code = (
        "import sys, warnings, numpy as np\n"
        "from tui.cli import main\n"
        "import tui.cli.session_commands as c\n"
        "def warn(args):\n"
        "    np.exp(np.array([1e308]))\n"
        "    warnings.warn('overflow encountered', RuntimeWarning)\n"
        "    return 0\n"
        "sys.argv = ['loopcraft', 'examples']\n"
        "c.cmd_examples = warn\n"
        "from tui.cli import build_parser\n"
        "sys.exit(main())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert "RuntimeWarning" not in out.stderr and "Warning" not in out.stderr, out.stderr


def test_an_os_error_from_a_typed_path_is_a_message(surrogate_session, tmp_path, capsys):
    long = str(tmp_path / ("x" * 300) / "out.py")
    assert main(["export", str(surrogate_session), "--to", "python", "--out", long]) == 2
    err = capsys.readouterr().err
    assert "ENAMETOOLONG" in err and "Traceback" not in err

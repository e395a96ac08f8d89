"""An engine failure inside an algorithm names the algorithm once ("cip: ...",
never "cip: cip: ...")."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def test_a_failing_run_names_its_algorithm_once(tmp_path, capsys):
    path = tmp_path / "s.json"
    shutil.copy(EXAMPLES / "report003_lag_lead.json", path)
    doc = json.loads(path.read_text())
    doc["problem"]["conditions"][0]["plant"]["blocks"][0]["transfer"]["expression"] = "1e308"
    path.write_text(json.dumps(doc))
    assert main(["run", str(path)]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("loopcraft run: error: cip: ") and "cip: cip:" not in error

"""A finished run's stop is explained where the engineer looks (issue 51, section 2): under the
Run tab's tableau and in the status line, the constraint that binds and the requirement unmet."""

from __future__ import annotations

import json

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.cli import main


@synchronous
async def test_the_run_tab_names_what_binds_at_the_stop(tmp_path, capsys):
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s*(s+1))", "--compensator", "lead"]) == 0
    data = json.loads(path.read_text())
    data["problem"]["targets"][0]["bands"][0]["desired"] = 80.0  # PM 80 deg and a crossover of 5: out of reach
    data["problem"]["targets"].append({"measure": "crossover_frequency", "bands": [{"desired": 5.0}]})
    path.write_text(json.dumps(data))
    assert main(["run", str(path), "--until-done"]) == 0
    capsys.readouterr()
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        tableau = str(app.screen.query_one("#tableau").render())
        status = str(app.screen.query_one("#status").render())
        for text in (tableau, status):
            assert "'T1 <= 20*T2' binds" in text and "unmet: WC1" in text

"""A finished run's stop is explained where the engineer looks (issue 51, section 2): under the
Run tab's tableau and in the status line, the constraint that binds and the requirement unmet."""

from __future__ import annotations

import json

import pytest

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


@synchronous
async def test_the_plant_and_targets_tabs_mark_what_binds_at_the_design(tmp_path, capsys):
    """Issue 51, section 2: where a constraint is edited (Targets) and beside the parameters it
    names (Plant), whether it binds at the current design; the Run tab notes it after every step.
    The run stops on 'T1 <= 20*T2' (T1/T2 = 20 at its last design, checked here on the numbers)."""
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s*(s+1))", "--compensator", "lead"]) == 0
    data = json.loads(path.read_text())
    data["problem"]["targets"][0]["bands"][0]["desired"] = 80.0
    data["problem"]["targets"].append({"measure": "crossover_frequency", "bands": [{"desired": 5.0}]})
    path.write_text(json.dumps(data))
    assert main(["run", str(path), "--until-done"]) == 0
    capsys.readouterr()
    last = json.loads(path.read_text())["records"][-1]["parameters"]
    assert last["T1"] == pytest.approx(20 * last["T2"], rel=1e-6)
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert "note: 'T1 <= 20*T2' binds" in str(app.screen.query_one("#step-info").render())
        await pilot.press("2")
        table = app.screen.query_one("#parameters")
        marks = {str(table.get_row_at(r)[0]): str(table.get_row_at(r)[-1]) for r in range(table.row_count)}
        assert marks == {"K": "", "T1": "1 binds, 2", "T2": "1 binds, 2"}
        await pilot.press("3")
        rows = [str(cell) for cell in objective_values(app)]
        assert "T1 <= 20*T2  (binds at the design)" in rows and "T2 <= 20*T1  (holds at the design)" in rows


def objective_values(app) -> list:
    table = app.screen.query_one("#objective-table")
    return [table.get_row_at(r)[1] for r in range(table.row_count)]

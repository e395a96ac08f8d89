"""A fifth algorithm, installed beside loopcraft as a plug-in
(tests/plugins/loopcraft_test_algorithms/compass.py, one entry point in
tests/plugins/pyproject.toml), driven through the CLI, the workbench and a sweep
on the local Dask cluster: nothing registers it in the test process, every part
finds it through its entry point, and everything algorithm-specific reaches the
screens through its presenter."""

from __future__ import annotations

import json

import pytest

from tests.tui.test_app import settle, status, synchronous
from tui.app import LoopcraftApp
from tui.cli import main


def _compass_session(workdir):
    path = workdir / "report003_lag_lead.json"
    doc = json.loads(path.read_text())
    doc["algorithm"] = {"name": "compass", "settings": {"step": 0.4}}
    path.write_text(json.dumps(doc))
    return path


def test_the_cli_runs_reports_and_replays_it(workdir, capsys):
    path = _compass_session(workdir)
    assert main(["run", str(path), "--iterations", "3"]) == 0
    assert "compass: iteration 3" in capsys.readouterr().out
    assert main(["report", str(path)]) == 0
    report = capsys.readouterr().out
    assert report.startswith("COMPASS SEARCH ITERATION 3  MERIT")
    assert main(["replay", str(path)]) == 0
    assert "all 3 recorded iterations reproduce" in capsys.readouterr().out


@pytest.mark.long
def test_a_sweep_ranks_its_runs_by_the_presenters_value(workdir, capsys):
    path = _compass_session(workdir)
    assert main(["sweep", str(path), "--starts", "3", "--workers", "2", "--json"]) == 0  # a local Dask cluster
    summary = json.loads(capsys.readouterr().out)
    runs = summary["runs"]
    assert len(runs) == 3 and all(r["status"] != "failed" for r in runs)
    assert summary["workers"] == 2 and all(r["worker"].startswith("tcp://") for r in runs)  # Dask workers found it
    assert all(isinstance(r["ranking"], float) for r in runs)  # the presenter's ranking: the merit
    best = [o["ranking"] for o in summary["optima"]]
    assert best == sorted(best)  # smaller merit first (maximize False)


@synchronous
async def test_the_workbench_steps_it_and_shows_its_own_lines(workdir):
    app = LoopcraftApp(_compass_session(workdir))
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        assert "Iteration 1" in status(app) and "compass" in status(app)
        info = str(app.screen.query_one("#step-info").render())
        assert "compass step" in info and "probes" in info
        app.screen.query_one("#plots").active = "p-convergence"  # plots are drawn when shown
        await settle(app, pilot)
        convergence = app.screen.query_one("#convergence").figure
        assert convergence.ylabel == "compass merit" and len(convergence.series[0].x) == 1

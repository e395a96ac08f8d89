"""The bundled digital example in the app: its tableau in rad/s and its poles in z, the same
numbers the command line gives (tests/sessions/test_sampled_sessions.py checks those against
python-control and the unit circle); run to convergence by the keys, it ends where `loopcraft run` does."""

from __future__ import annotations

import shutil

import pytest

from sessions.store import load_session
from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.cli import main
from tui.figures.closed_loop import pole_lines

EXAMPLE = "coebra_kuo_z.json"


@pytest.mark.long
@synchronous
async def test_the_z_example_reads_and_runs_in_the_app_as_on_the_command_line(workdir, tmp_path):
    cli = tmp_path / "cli" / EXAMPLE
    cli.parent.mkdir()
    shutil.copy(workdir / EXAMPLE, cli)
    assert main(["run", str(cli), "--iterations", "40"]) == 0
    expected = load_session(cli).records[-1]
    app = LoopcraftApp(workdir / EXAMPLE)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.bench.iteration == 0
        lines = pole_lines(app.bench.view())
        assert "pole (z)" in lines and "0.50383 +- 0.8222j" in lines  # |z| < 1: the stable start
        await pilot.press("r")
        for _ in range(200):
            await settle(app, pilot)
            if app.bench.iteration and app.bench.session.records[-1].status.value != "running":
                break
        record = app.bench.session.records[-1]
        assert record.iteration == expected.iteration
        for name, value in expected.parameters.items():
            assert record.parameters[name] == pytest.approx(value, rel=1e-12)
        measures = {m.kind: m for m in record.measures}
        assert measures["gain_margin_db"].value == pytest.approx(16.0011, abs=1e-4)
        assert measures["gain_margin_db"].frequency == pytest.approx(2.03749, rel=1e-5)  # rad/s

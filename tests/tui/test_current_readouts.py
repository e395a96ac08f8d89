"""Every readout shows the current design (issue 54, section 2): after a run, an undo, a
reopen at a later iteration, an adoption and an algorithm switch, the shaping table
(`C`), `e`'s prompt, the tableau, the plots and the status line read the design the moves
act on: the current iteration's, never the start's.  The tableau's margins and the Bode
plot's curve are checked against python-control's of that design."""

from __future__ import annotations

import control
import numpy as np
import pytest

from tests.tui.test_app import settle, status, synchronous
from tests.tui.test_shape_table import lead_app
from tui.app import LoopcraftApp
from tui.figures.catalog import figure_key
from tui.screens.dialogs import StartDialog

PLANT = control.tf([1], [1, 10, 0, 0])  # lead_app's 1/(s^2 (s+10))


def current(app) -> dict[str, float]:
    """The current design's parameter values (the last record's, else the start's)."""
    records = app.bench.records
    return (
        dict(records[-1].parameters)
        if records
        else {p.name: p.value for p in app.bench.session.model.problem.parameters}
    )


def shown(app) -> dict[str, float]:
    """What the shaping table reads: the gain and the zero's and pole's frequencies."""
    from engine.design.compensator_items import measure

    table = app.screen.query_one("#shape")
    return {name.split(".")[1]: measure(item) for name, item in zip(table.names, table.found)}


def assert_current(app) -> None:
    values = current(app)
    readouts = shown(app)
    assert readouts["gain"] == pytest.approx(values["K"], rel=1e-9)
    assert readouts["zero1"] == pytest.approx(1 / values["T1"], rel=1e-9)
    assert readouts["pole1"] == pytest.approx(1 / values["T2"], rel=1e-9)
    assert f"Iteration {app.bench.iteration}" in status(app)


def loop(values: dict[str, float]) -> control.TransferFunction:
    """The lead's loop K (1 + T1 s) / (1 + T2 s) / (s^2 (s+10)) at ``values``."""
    return control.tf([values["K"] * values["T1"], values["K"]], [values["T2"], 1]) * PLANT


def tableau_value(app, kind: str) -> tuple[float, float]:
    """The value and frequency the tableau shows on its ``kind`` row ("PM deg")."""
    line = next(line for line in app.screen.query_one("#tableau").text.plain.split("\n") if line.startswith(kind))
    words = line[len(kind) :].split()
    return float(words[0]), float(words[-1])


async def assert_drawn_current(app, pilot) -> None:
    """The tableau's PM and GM (value and frequency) are python-control's of the current design,
    and the Bode plot shows that design: its key the current view's, its magnitude curve
    20 log10 |L(jw)| at each point.  A tableau or plot left on the start (or an earlier design) fails."""
    gm, pm, wcg, wcp = control.margin(loop(current(app)))
    assert tableau_value(app, "PM deg") == pytest.approx((pm, wcp), rel=2e-4)
    assert tableau_value(app, "GM dB") == pytest.approx((20 * np.log10(gm), wcg), rel=2e-4)
    app.screen.query_one("#plots").active = "p-bode"
    await settle(app, pilot)
    assert app.screen._figure_keys["bode-mag"] == figure_key(app.bench.view())
    curve = next(s for s in app.screen.query_one("#bode-mag").figure.series if s.label == "current")
    w = 10.0 ** np.array(curve.x)
    assert curve.y == pytest.approx(20 * np.log10(abs(loop(current(app))(1j * w))), abs=1e-6)
    app.screen.query_one("#plots").active = "p-nyquist"
    await settle(app, pilot)


async def _shaped_and_run(app, pilot) -> None:
    """C, the gain for a 1 rad/s crossover, then r: a run that moves the design."""
    await settle(app, pilot)
    await pilot.press("C")
    await settle(app, pilot)
    await pilot.press("g")
    await pilot.pause()
    app.screen.query_one("#value").value = "1"
    await pilot.press("enter")
    await settle(app, pilot)
    start = current(app)
    await pilot.press("r")
    await settle(app, pilot)
    assert app.bench.iteration > 0 and current(app)["K"] != pytest.approx(start["K"], rel=1e-6)


@pytest.mark.long
@synchronous
async def test_the_shaping_table_and_prompt_read_the_design_after_a_run_and_an_undo(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await _shaped_and_run(app, pilot)
        assert_current(app)
        await assert_drawn_current(app, pilot)
        table = app.screen.query_one("#shape")
        table.focus()
        table.move_cursor(row=table.names.index("compensator.zero1"))
        await pilot.press("e")
        await pilot.pause()
        prompt = str(app.screen.query_one("Label").render())
        assert f"now {1 / current(app)['T1']:.6g}" in prompt
        await pilot.press("escape")
        await pilot.press("z")  # an iteration undone
        await settle(app, pilot)
        assert_current(app)
        await assert_drawn_current(app, pilot)


@synchronous
async def test_a_session_reopened_at_a_later_iteration_reads_its_design(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await _shaped_and_run(app, pilot)
        await pilot.press("ctrl+s")
        await settle(app, pilot)
        path = app.bench.session.path
    again = LoopcraftApp(path)
    async with again.run_test(size=(120, 40)) as pilot:
        await settle(again, pilot)
        assert again.bench.iteration > 0
        await pilot.press("C")
        await settle(again, pilot)
        assert_current(again)
        await assert_drawn_current(again, pilot)


@pytest.mark.long
@synchronous
async def test_adoption_and_an_algorithm_switch_read_the_design_kept(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await _shaped_and_run(app, pilot)
        design = current(app)
        await pilot.press("d")  # adopt: asks, then the design on screen is the start
        await pilot.pause()
        await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.iteration == 0 and current(app)["K"] == pytest.approx(design["K"], rel=1e-12)
        assert_current(app)
        await assert_drawn_current(app, pilot)
        await pilot.press("r")
        await settle(app, pilot)
        await pilot.press("a")  # another algorithm: the records go, the design on screen is kept
        await pilot.pause()
        names = [name for name, _ in app.screen.choices]
        other = next(name for name in names if name != app.bench.algorithm_name and name in ("cip", "qcg"))
        app.screen.query_one("OptionList").highlighted = names.index(other)
        await pilot.press("enter")
        await pilot.pause()
        if isinstance(app.screen, StartDialog):  # which design to start from: the one on screen
            await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.algorithm_name == other
        assert_current(app)
        await assert_drawn_current(app, pilot)


@pytest.mark.long
@synchronous
async def test_a_hidden_tab_is_drawn_from_the_current_design_when_shown(tmp_path, monkeypatch):
    """A nudge on the Run tab redraws no hidden table (issue 54's latency); the Plant tab
    shown after a run and a nudge reads the design then, not the one it last drew."""
    from tui.screens.main import MainScreen

    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.press("2")  # the Plant tab drawn once, at the start
        await settle(app, pilot)
        await _shaped_and_run(app, pilot)
        drawn = []
        monkeypatch.setattr(MainScreen, "refresh_plant", lambda screen: drawn.append(1))
        await pilot.press("right")  # a nudge of the gain on the Run tab (its design the start)
        await pilot.pause()
        assert isinstance(app.screen, StartDialog)
        await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.iteration == 0 and drawn == []
        monkeypatch.undo()
        await pilot.press("2")
        await settle(app, pilot)
        table = app.screen.query_one("#parameters")
        row = [r for r in range(table.row_count) if table.get_row_at(r)[0] == "K"][0]
        assert float(table.get_row_at(row)[1]) == pytest.approx(current(app)["K"], rel=1e-5)

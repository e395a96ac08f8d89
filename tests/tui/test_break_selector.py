"""The break selector (issue 57): `b` draws Bode, Nyquist and Nichols at the next loop break of
the two-path autopilot (tests/sessions/test_two_path_breaks: breaks dc, u_att, u_rate), the
other loops closed; the pole map stays the whole closed loop's; the tableau lists every break's
margins and the multi-loop disk margin.  The loop drawn at u_att is, independently,
python-control's -KA/s * feedback(B A, R, +1); the lines' multi-loop disk margin is checked
against scipy's D-scale mu in tests/sessions/test_two_path_breaks."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from tests.sessions.test_two_path_breaks import document, loop_at_u_att, phase_margin
from tests.tui.test_app import select_row, settle, synchronous
from tui.app import LoopcraftApp
from tui.screens.main import PLOT_TABS

control = pytest.importorskip("control")


async def shown(app, pilot, plot: str):
    """The Run tab's plot ``plot`` brought on screen (p cycles them) and drawn: its figure."""
    tab = next(tab for tab, ids in PLOT_TABS.items() if plot.removeprefix("#") in ids)
    for _ in range(len(app.screen.plot_tabs) + 1):
        if app.screen.query_one("#plots").active == tab:
            break
        await pilot.press("p")
    await settle(app, pilot)
    return app.screen.query_one(plot).figure


def bode_points(app) -> tuple[np.ndarray, np.ndarray]:
    """The Bode magnitude's curve as drawn: log10(omega) and dB at every grid point (its probe)."""
    probe = app.screen.query_one("#bode-mag").figure.probe
    return np.array(probe.x), np.array(probe.y)


@synchronous
async def test_b_draws_the_loop_at_the_next_break_with_the_others_closed(tmp_path):
    path = tmp_path / "two_paths.json"
    path.write_text(json.dumps(document()))
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert (await shown(app, pilot, "#nyquist")).title == "Nyquist (GH plane) at dc"
        poles = [s.x for s in (await shown(app, pilot, "#poles")).series]
        await pilot.press("b")
        await settle(app, pilot)
        assert app.bench.plotted_break == "u_att"
        assert any("the loop at u_att" in str(n.message) for n in app._notifications)
        assert [s.x for s in (await shown(app, pilot, "#poles")).series] == poles  # the whole closed loop's
        for plot, title in (
            ("#nyquist", "Nyquist (GH plane)"),
            ("#nichols", "Nichols"),
            ("#bode-mag", "Bode magnitude"),
        ):
            assert (await shown(app, pilot, plot)).title == f"{title} at u_att"
        log_w, db = bode_points(app)
        expected = loop_at_u_att(1.0, 0.1)(1j * 10**log_w)
        np.testing.assert_allclose(db, 20 * np.log10(np.abs(expected)), atol=1e-9)
        tableau = str(app.screen.query_one("#tableau").render())
        pm, wc = phase_margin(loop_at_u_att(1.0, 0.1))
        row = re.search(r"PM@u_att\s+(\S+) deg\s+(\S+)", tableau)
        assert row is not None, tableau
        assert float(row[1]) == pytest.approx(pm, rel=1e-4) and float(row[2]) == pytest.approx(wc, rel=1e-4)
        assert re.search(r"MDM\s+\S+ alpha\s+\S+\n  multi-loop disk margin, every break at once: certified", tableau)
        for _ in range(2):  # u_rate, then the primary break again
            await pilot.press("b")
        await settle(app, pilot)
        assert app.bench.plotted_break is None
        assert (await shown(app, pilot, "#bode-mag")).title == "Bode magnitude at dc"
        assert app.bench.session.model.model_dump_json().count("plotted") == 0  # view state, never saved


@synchronous
async def test_b_is_disabled_with_its_reason_on_a_single_break_session(tmp_path):
    data = document([{"measure": "phase_margin_deg", "bands": [{"desired": 40.0}]}])
    del data["problem"]["conditions"][0]["breaks"]
    path = tmp_path / "one_break.json"
    path.write_text(json.dumps(data))
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.check_action("next_break", ()) is None  # dimmed
        assert "one loop break" in (app.key_reason("next_break") or "")
        await pilot.press("b")
        await settle(app, pilot)
        assert app.bench.plotted_break is None
        assert any("one loop break" in str(n.message) for n in app._notifications)
        assert (await shown(app, pilot, "#bode-mag")).title == "Bode magnitude"
        assert "every break" not in str(app.screen.query_one("#tableau").render())


def test_the_loop_plots_draw_the_requirements_of_the_targets_read_at_their_break(tmp_path):
    """PM >= 40 at dc (13.8 deg: unmet) and PM >= 10 at u_att (14.6 deg: met): the Bode at dc draws
    the first alone, at u_att the second alone, each judged by its own row (PM1, PM1@u_att)."""
    from dataclasses import replace

    from sessions.store import load_session
    from tui.figures.requirements import requirements
    from tui.state.workbench import Workbench

    path = tmp_path / "two_paths.json"
    targets = [
        {"measure": "phase_margin_deg", "bands": [{"desired": 40.0}]},
        {"measure": "phase_margin_deg", "break": "u_att", "bands": [{"desired": 10.0}]},
    ]
    path.write_text(json.dumps(document(targets)))
    view = Workbench(load_session(path)).view()
    assert [(r.value, r.met) for r in requirements(view)] == [(40.0, False)]
    at_u_att = replace(view, plotted_break="u_att")
    assert at_u_att.break_title() == " at u_att" and at_u_att.at_chosen_break()
    assert [(r.value, r.met) for r in requirements(at_u_att)] == [(10.0, True)]


@synchronous
async def test_b_picks_the_break_from_the_history_table_and_enter_starts_again_there(tmp_path):
    """Before, the History table's own b (start again from here) shadowed the app's break key there
    (Textual asks the focused widget first): b left plotted_break None.  Now b is the break key
    everywhere and the table's start-again is enter, which asks first."""
    path = tmp_path / "two_paths.json"
    path.write_text(json.dumps(document()))
    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        await select_row(app, pilot, "4", "history-table", 0)
        await settle(app, pilot)
        assert app.screen.query_one("#history-table").has_focus
        await pilot.press("b")
        await settle(app, pilot)
        assert app.bench.plotted_break == "u_att"
        assert app.screen.query_one("#history-plot").figure.title == "Nyquist at u_att: start"
        await pilot.press("enter")
        await pilot.pause()
        assert app.bench.iteration == 1  # asked first
        await pilot.press("y")
        await settle(app, pilot)
        assert app.bench.iteration == 0

"""Shaping by hand in the workbench (issue 38, sections 1 and 3): C shows the compensator's
items under the tableau; left/right move the selected one, e types it, g and G solve the
loop gain exactly; a burst of nudges on one item is one undo step; every result checked
against python-control on the design the keys made."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

from engine.analysis import loop_curve
from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.cli import main

PLANT = ct.tf([1], [1, 10, 0, 0])


def start_values(app) -> dict[str, float]:
    return {p.name: p.value for p in app.bench.session.model.problem.parameters}


def _loop(values) -> ct.TransferFunction:
    return ct.tf([values["K"] * values["T1"], values["K"]], [values["T2"], 1]) * PLANT


def lead_app(tmp_path, monkeypatch) -> LoopcraftApp:
    """The app on a new lead session for 1/(s^2 (s+10)): K*(1+T1*s)/(1+T2*s)."""
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    return LoopcraftApp(path)


async def _typed(app, pilot, key: str, text: str) -> None:
    await pilot.press(key)
    await pilot.pause()
    app.screen.query_one("#value").value = text
    await pilot.press("enter")
    await settle(app, pilot)


@synchronous
async def test_a_lead_shaped_by_keys(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        table = app.screen.query_one("#shape")
        assert app.focused is table and table.names == ["compensator.gain", "compensator.zero1", "compensator.pole1"]
        await _typed(app, pilot, "g", "1")  # the gain for a 1 rad/s crossover
        assert abs(_loop(start_values(app))(1j)) == pytest.approx(1.0, rel=1e-10)
        assert table.check_action("damp", ()) is None  # the gain is no pair: [ ] disabled
        await pilot.press("down")
        before = start_values(app)
        await pilot.press(*["left"] * 6)  # the zero 5 % lower, six times: one burst
        await settle(app, pilot)
        after = start_values(app)
        assert after["T1"] == pytest.approx(before["T1"] * 1.05**6, rel=1e-9) and after["K"] == before["K"]
        assert app.bench.edits.last.startswith("edit: T1 value: 1 -> 1.34")
        await _typed(app, pilot, "G", "45")  # then the gain for a 45 deg phase margin: two gains give it
        assert [text.split(":")[0] for _, text in app.screen.choices] == [
            "crossover 1.25981 rad/s",
            "crossover 2.5664 rad/s",
        ]
        await pilot.press("enter")  # the default (no met requirement broken): the lowest crossover
        await settle(app, pilot)
        _, pm, _, _, wc, _ = ct.stability_margins(_loop(start_values(app)))
        assert pm == pytest.approx(45.0, abs=1e-6) and wc > 1.0
        await pilot.press("down")
        await _typed(app, pilot, "e", "12")  # the pole typed at 12 rad/s (the session keeps T1 <= 20 T2)
        assert start_values(app)["T2"] == pytest.approx(1 / 12, rel=1e-10)
        for _ in range(3):  # the pole, the PM gain, the burst: three undo steps
            await pilot.press("ctrl+z")
            await settle(app, pilot)
        assert start_values(app)["T1"] == before["T1"] and start_values(app)["K"] == before["K"]


TUTORIAL = ["C", "g", "1", "enter", "down"]  # docs/tutorial.md, "Shaping a lead by hand"


@pytest.mark.long
@synchronous
async def test_the_tutorials_lead_takes_well_under_thirty_keys(tmp_path, monkeypatch):
    """The issue's lead for 1/(s^2 (s+10)) by hand: the gain for a 1 rad/s crossover, then the
    zero nudged down until PM >= 45 deg (python-control's margins of the design on screen)."""
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        keys = 0
        for key in TUTORIAL:
            if key == "1":
                app.screen.query_one("#value").value = "1"
            else:
                await pilot.press(key)
            keys += 1
            await settle(app, pilot)
        while ct.stability_margins(_loop(start_values(app)))[1] < 45 and keys < 30:
            await pilot.press("left")
            await settle(app, pilot)
            keys += 1
        gm, pm, _, _, wc, _ = ct.stability_margins(_loop(start_values(app)))
        print(f"keys {keys}: PM {pm:.2f} deg, GM {20 * math.log10(gm):.2f} dB, crossover {wc:.4g} rad/s")
        assert pm >= 45 and keys == 12 and 20 * math.log10(gm) >= 8 and wc >= 1.0


@pytest.mark.long
@synchronous
async def test_parts_added_and_an_item_deleted_by_keys(tmp_path, monkeypatch):
    """+ adds a notch about the crossover (its zero and pole pairs, wn and zeta named for
    what they are), - deletes the lead's zero with its factor, its parameter and the
    constraint on it (asked first); the loop checked against python-control."""
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        wc = ct.stability_margins(_loop(start_values(app)))[4]
        await pilot.press("plus")
        await pilot.pause()
        option = app.screen.query_one("OptionList")
        option.highlighted = [k for k, _ in app.screen.choices].index("notch")
        await pilot.press("enter")
        await settle(app, pilot)
        block = app.bench.session.model.problem.conditions[0].plant.blocks[0].transfer
        assert block.expression == (
            "K*(1+T1*s)*(1+2*notch1_zz*s/notch1_wz+(s/notch1_wz)^2)/((1+T2*s)*(1+2*notch1_zp*s/notch1_wp+(s/notch1_wp)^2))"
        )
        values = start_values(app)
        assert values["notch1_wz"] == values["notch1_wp"] == pytest.approx(wc, rel=1e-6)
        table = app.screen.query_one("#shape")
        assert {"compensator.zeropair1", "compensator.polepair1"} <= set(table.names)
        wn = values["notch1_wz"]  # the notch where loopcraft placed it (its crossover, checked above to 1e-6)
        notch = ct.tf([1 / wn**2, 2 * 0.05 / wn, 1], [1 / wn**2, 2 * 0.5 / wn, 1])
        w = np.array([0.3 * wc, wc, 3 * wc])
        c = app.bench.session.problem.conditions[0]
        ours = loop_curve(c.network, c.break_at, w, app.bench.session.problem.condition_values(0), "").gh
        assert np.allclose(ours, (_loop(values) * notch)(1j * w), rtol=1e-12)
        table.move_cursor(row=table.names.index("compensator.zero1"))
        await pilot.press("minus")
        await pilot.pause()
        await pilot.press("y")  # asked first
        await settle(app, pilot)
        block = app.bench.session.model.problem.conditions[0].plant.blocks[0].transfer
        assert block.expression.startswith("K*(1+2*notch1_zz*s/notch1_wz+(s/notch1_wz)^2)/")
        assert "T1" not in start_values(app) and not any(
            "T1" in str(c) for c in app.bench.session.model.problem.constraints
        )
        await pilot.press("ctrl+z")  # one undo brings the zero, T1 and its constraint back
        await settle(app, pilot)
        assert "T1" in start_values(app) and any("T1" in str(c) for c in app.bench.session.model.problem.constraints)


@pytest.mark.long
@synchronous
async def test_a_notch_on_a_resonance_puts_its_zeros_on_the_modes_poles(workdir):
    """N lists the plant's lightly damped pole pairs (the launch vehicle's bending modes,
    read off each block: 11, 24, 38 rad/s) and adds a notch whose zeros are the chosen
    mode's poles exactly."""
    from engine.design.compensator_items import items
    from engine.model.blocks import ExpressionTransfer

    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        await pilot.press("N")
        await pilot.pause()
        assert [text.split(" (")[0] for _, text in app.screen.choices] == [
            "11 rad/s, zeta 0.01",
            "24 rad/s, zeta 0.01",
            "38 rad/s, zeta 0.015",
        ]
        app.screen.query_one("OptionList").highlighted = 1
        await pilot.press("enter")
        await settle(app, pilot)
        model = app.bench.session.model.problem
        text = model.conditions[0].plant.blocks[19].transfer.expression
        assert text == (
            "KD*(1+2*notch1_zz*s/notch1_wz+(s/notch1_wz)^2)/((1+TA*s)*(1+2*notch1_zp*s/notch1_wp+(s/notch1_wp)^2))"
        )
        values = app.bench.session.problem.condition_values(0)
        (pair,) = [i for i in items(ExpressionTransfer(text), values) if i.kind == "zero pair"]
        mode = complex(-0.24, (576 - 0.24**2) ** 0.5)  # s^2 + 0.48 s + 576
        assert abs(pair.root - mode) <= 1e-12 * abs(mode)
        table = app.screen.query_one("#shape")
        table.move_cursor(row=table.names.index("attitude path.zeropair1"))
        await pilot.press("right_square_bracket", "left_square_bracket", "right_square_bracket")  # one burst
        await settle(app, pilot)
        values = app.bench.session.problem.condition_values(0)
        (moved,) = [i for i in items(ExpressionTransfer(text), values) if i.kind == "zero pair"]
        assert -moved.root.real / abs(moved.root) == pytest.approx(0.01 * 1.1, rel=1e-9)  # zeta x 1.1 / 1.1 x 1.1
        assert abs(moved.root) == pytest.approx(24.0, rel=1e-9)  # wn kept


class _SlowClock:
    """A clock on a loaded machine: every reading ten seconds after the last."""

    def __init__(self) -> None:
        self.now = 0.0

    def monotonic(self) -> float:
        self.now += 10.0
        return self.now


@pytest.mark.long
@synchronous
async def test_a_burst_is_what_the_user_did_not_a_timer(tmp_path, monkeypatch):
    """Nudges by one key repeated are one undo step however slowly they come (a clock
    that jumps 10 s between readings once split them); another key between splits them."""
    from tui.state import edit_history

    monkeypatch.setattr(edit_history, "time", _SlowClock(), raising=False)
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        await pilot.press("down")
        steps = len(app.bench.edits.undo_stack)
        for _ in range(4):
            await pilot.press("left")
            await settle(app, pilot)
        assert len(app.bench.edits.undo_stack) == steps + 1
        await pilot.press("down", "up", "left")  # another key between: a new burst
        await settle(app, pilot)
        assert len(app.bench.edits.undo_stack) == steps + 2
        await pilot.press("right")  # another key on the same item: a new burst too
        await settle(app, pilot)
        assert len(app.bench.edits.undo_stack) == steps + 3


@synchronous
async def test_a_nudge_repaints_its_readouts_without_a_layout_pass_or_a_footer_rebuilt(tmp_path, monkeypatch):
    """A nudge changes no size and no key (issue 54): the shaping table's reading changes in
    its cell (no rows made anew), the pole lines while computed keep the tableau's height,
    so the screen is not laid out again and the footer not rebuilt; every readout is the
    design's (the tableau's phase margin python-control's).  Before, each nudge laid the
    screen out about five times (the rows made again, the tableau a line tall then long)."""
    from textual.screen import Screen

    from tui.widgets.footer import Footer

    app = lead_app(tmp_path, monkeypatch)
    passes, rebuilt = [], []
    layout, recompose = Screen._refresh_layout, Footer.recompose

    def laid_out(screen, *args, **kwargs):
        passes.append(screen._layout_required)
        return layout(screen, *args, **kwargs)

    async def recomposed(footer):
        rebuilt.append(footer)  # (recomposed only when its keys change)
        await recompose(footer)

    monkeypatch.setattr(Screen, "_refresh_layout", laid_out)
    monkeypatch.setattr(Footer, "recompose", recomposed)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C", "down", "right")  # the zero: a first nudge
        await settle(app, pilot)
        table = app.screen.query_one("#shape")
        row = table.get_row_at(1)
        passes.clear()
        rebuilt.clear()
        for key in ("left", "right", "left"):  # readings no longer than the first nudge's: no column widened
            await pilot.press(key)
            await settle(app, pilot)
        assert not any(passes) and rebuilt == []
        values = start_values(app)
        assert table.get_row_at(1)[1] == f"zero at {1 / values['T1']:.6g} rad/s (T {values['T1']:.6g} s) [T1]" != row[1]
        _, pm, _, _, _, _ = ct.stability_margins(_loop(values))
        rows, _ = app.bench.view().tableau()
        assert next(r.value for r in rows if r.kind == "phase_margin_deg") == pytest.approx(pm, abs=1e-6)
        assert "computing" not in app.screen.query_one("#tableau").text.plain


@synchronous
async def test_a_nudge_repaints_the_readouts_it_changed_and_walks_no_widget_tree(tmp_path, monkeypatch):
    """A nudge's paint holds what changed (the tableau, the status line's edit, the table's
    reading), not the step lines it left as they were (before, every text was set again and
    repainted: a paint over the screen's whole height), and finding the plots to draw walks
    no widget tree (before, a query over every tab's widgets each nudge)."""
    from textual.dom import DOMNode

    from tui.widgets.plots import FigurePlot
    from tui.widgets.textview import TextView

    app = lead_app(tmp_path, monkeypatch)
    repainted, queried = [], []
    refresh, query = TextView.refresh, DOMNode.query

    def noted_refresh(view, *args, **kwargs):
        repainted.append(view.id)
        return refresh(view, *args, **kwargs)

    def noted_query(node, selector=None):
        queried.append(selector)
        return query(node, selector)

    monkeypatch.setattr(TextView, "refresh", noted_refresh)
    monkeypatch.setattr(DOMNode, "query", noted_query)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C", "down", "right")
        await settle(app, pilot)
        step_lines = app.screen.query_one("#step-info").text.plain
        repainted.clear()
        queried.clear()
        for key in ("left", "right"):
            await pilot.press(key)
            await settle(app, pilot)
        assert {"tableau", "status"} <= set(repainted) and "step-info" not in repainted
        assert app.screen.query_one("#step-info").text.plain == step_lines
        assert FigurePlot not in queried


@synchronous
async def test_a_nudges_handler_does_each_job_once(tmp_path, monkeypatch):
    """A nudge's handler (issue 54, section 3) reads the compensator's items at a design once
    (the shaping table's fill after one nudge is what the next nudge's move starts from:
    before, both found the parameters that own each item again, two passes a nudge), sets the
    algorithm up once (the tableau's first record) and leaves the autosave's write to its
    thread, as an undo of the edits does (before, both waited for it every AUTOSAVE_INTERVAL)."""
    from engine.design import compensator_items
    from sessions import lifecycle, store

    app = lead_app(tmp_path, monkeypatch)
    owners, setups, waits = [], [], []
    owned, stepper, write = compensator_items._owned, lifecycle.stepper, store.write_autosave

    def noted_owned(slopes, value, *args):
        owners.append(value)  # one parameter's items, read from its exact derivatives
        return owned(slopes, value, *args)

    def noted_stepper(session):
        setups.append(session)
        return stepper(session)

    def noted_write(session, at_most_every=0.0, wait=True):
        waits.append(wait)
        return write(session, at_most_every, wait)

    monkeypatch.setattr(compensator_items, "_owned", noted_owned)
    monkeypatch.setattr(compensator_items, "_moved", lambda *a: pytest.fail("a lead's parameter nudged"))
    monkeypatch.setattr(lifecycle, "stepper", noted_stepper)
    monkeypatch.setattr("tui.state.bench.persistence.write_autosave", noted_write)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C", "down", "right")
        await settle(app, pilot)
        owners.clear(), setups.clear(), waits.clear()
        nudges = ("right", "right", "right")  # three new designs (back and forth would find those kept)
        for key in nudges:
            await pilot.press(key)
            await settle(app, pilot)
        parameters = ["K", "T1", "T2"]  # K (1 + T1 s) / (1 + T2 s): each read once per design
        assert len(owners) == len(parameters) * len(nudges)
        assert len(setups) == len(nudges) and waits and not any(waits)
        waits.clear()
        await pilot.press("ctrl+z")  # the edits' undo: its autosave left to the thread too
        await settle(app, pilot)
        assert waits and not any(waits)


@synchronous
async def test_a_bursts_later_nudges_copy_nothing_and_a_refused_one_keeps_its_undo_step(tmp_path, monkeypatch):
    """The nudges of a burst after its first copy no snapshot of the session (issue 54,
    section 3: the burst's undo step is its first snapshot; before, each nudge copied the
    problem and the algorithm, 1-3 ms, and dropped the copy), compare against the first
    snapshot's JSON made once, and a nudge refused (past the parameter's bound) leaves the
    design and the burst's one undo step as they were."""
    import json

    from tui.state import edit_history

    lead_app(tmp_path, monkeypatch)
    path = tmp_path / "lead.json"
    data = json.loads(path.read_text())
    for p in data["problem"]["parameters"]:
        if p["name"] == "T1":
            p["max"] = 1.12  # the zero's time constant: two nudges down in frequency and no more
    path.write_text(json.dumps(data))
    app = LoopcraftApp(path)
    copied, dumped = [], []
    of, dump = edit_history.Snapshot.of.__func__, edit_history._dump

    def noted_of(cls, book):
        copied.append(book)
        return of(cls, book)

    def noted_dump(*args):
        dumped.append(args)
        return dump(*args)

    monkeypatch.setattr(edit_history.Snapshot, "of", classmethod(noted_of))
    monkeypatch.setattr(edit_history, "_dump", noted_dump)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C", "down")
        await settle(app, pilot)
        steps = len(app.bench.edits.undo_stack)
        await pilot.press("left")  # T1 1 -> 1.05: the burst's first nudge, its snapshot
        await settle(app, pilot)
        assert len(copied) == 1
        copied.clear(), dumped.clear()
        await pilot.press("left", "left")  # T1 -> 1.1025, then past 1.12: refused
        await settle(app, pilot)
        assert copied == [] and len(dumped) == 1  # the design after the second nudge; the first's JSON kept
        assert start_values(app)["T1"] == pytest.approx(1.05**2, rel=1e-12)
        assert len(app.bench.edits.undo_stack) == steps + 1
        await pilot.press("ctrl+z")
        await settle(app, pilot)
        assert start_values(app)["T1"] == 1.0 and len(app.bench.edits.undo_stack) == steps

"""Undo and redo of edits (ctrl+z / ctrl+y) apart from iterations (z / Z), each saying what it did."""

from __future__ import annotations

from sessions.store import load_session
from tests.tui.test_app import edit_row, settle, status, synchronous
from tui.app import LoopcraftApp
from tui.state.edit_history import describe_change
from tui.state.workbench import Workbench


def test_a_change_is_described_by_name_and_value():
    before = {"parameters": [{"name": "K", "value": 1.0, "min": 0.0}], "targets": [{"measure": "gain_margin"}]}
    after = {"parameters": [{"name": "K", "value": 2.0, "min": 0.0}], "targets": [{"measure": "gain_margin"}]}
    assert describe_change(before, after) == "K value: 1 -> 2"
    assert describe_change(before, before) is None
    grown = {"parameters": before["parameters"] * 2, "targets": before["targets"]}
    assert describe_change(before, grown).startswith("parameters: ")


@synchronous
async def test_edits_undo_and_redo_with_their_descriptions_and_the_records_they_dropped(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 1
        before = app.bench.session.model.problem.model_dump()
        await edit_row(app, pilot, "2", "blocks", 0)
        app.screen.query_one("#value").value = "(s+z1)*(s+z2)/((s+p1)*(s+p2))*2"
        await pilot.press("enter")
        await pilot.pause()
        await pilot.press("y")  # the recorded iteration will be dropped: yes
        await settle(app, pilot)
        assert app.bench.iteration == 0
        assert "*2" in status(app) and "edit:" in status(app)
        await pilot.press("ctrl+z")
        await settle(app, pilot)
        assert app.bench.session.model.problem.model_dump() == before
        assert app.bench.iteration == 1 and "undid:" in status(app)  # the dropped iteration is back
        assert app.bench.view().loop_curve().gh is not None
        await pilot.press("ctrl+y")
        await settle(app, pilot)
        assert "*2" in app.bench.session.model.problem.conditions[0].plant.blocks[0].transfer.expression
        assert app.bench.iteration == 0 and "redid:" in status(app)
        await pilot.press("ctrl+y")  # nothing left to redo: the key is disabled
        await settle(app, pilot)
        assert app.check_action("redo_edit", ()) is None


def test_an_undone_iteration_comes_back_with_redo_and_a_new_step_forgets_it(workdir):
    bench = Workbench(load_session(workdir / "coebra_lag_lead.json"))
    records = [bench.step() for _ in range(3)]
    bench.undo()
    bench.undo()
    assert bench.iteration == 1 and bench.can_redo
    assert bench.redo() and bench.redo() and not bench.redo()
    assert [r.to_json() for r in bench.records] == [r.to_json() for r in records]
    fresh = Workbench(load_session(workdir / "coebra_lag_lead.json"))
    for _ in range(3):
        fresh.step()
    assert fresh.session.model.state == bench.session.model.state
    bench.undo()
    bench.step()
    assert not bench.can_redo


@synchronous
async def test_a_paused_run_says_paused(workdir, monkeypatch):
    import asyncio
    import time

    app = LoopcraftApp(workdir / "cip_dual_channel.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        stepper = type(app.bench.ensure_stepper())  # a bound stepper is frozen: its class is patched
        step = stepper.step
        monkeypatch.setattr(stepper, "step", lambda self, state: (time.sleep(0.05), step(self, state))[1])  # pausable
        await pilot.press("r")
        await asyncio.sleep(0.3)
        await pilot.press("space")
        await settle(app, pilot)
        assert 0 < app.bench.iteration and "paused" in status(app)
        await pilot.press("s")
        await settle(app, pilot)
        assert "paused" not in status(app)


def test_an_edit_is_described_without_a_python_repr():
    """'edit: targets: [{'measure': ...' was the status line after adding a target."""
    from tui.state.edit_history import describe_change

    one = {"problem": {"targets": [{"measure": "phase_margin_deg", "bands": [{"desired": 45.0}]}]}}
    two = {"problem": {"targets": one["problem"]["targets"] + [{"measure": "gain_margin_db", "bands": []}]}}
    assert describe_change(one, two) == "targets: added gain_margin_db"
    assert describe_change(two, one) == "targets: removed gain_margin_db"
    lines = describe_change({"problem": {"constraints": ["T1 >= 4*T2"]}}, {"problem": {"constraints": []}})
    assert lines == "constraints: T1 >= 4*T2 -> none" and "[" not in lines and "'" not in lines


def test_a_burst_back_at_its_start_leaves_the_step_before_it_alone():
    """A burst (a drag, nudges of one item) that comes back exactly where it began has no undo
    step; its next edit starts a step of its own (before, it still continued the burst, popped
    the earlier, unrelated edit's step and merged it into the drag's: one undo reverted both)."""
    from types import SimpleNamespace

    from tui.state.edit_history import EditHistory, Snapshot

    class Model:  # the two methods `EditHistory` asks of a problem model and an algorithm
        def __init__(self, value: float) -> None:
            self.value = value

        def model_dump(self) -> dict:
            return {"K": self.value}

    gain = {"K": 1.0}

    def book():
        return SimpleNamespace(
            session=SimpleNamespace(model=SimpleNamespace(problem=Model(gain["K"]), algorithm=Model(0)))
        )

    def edit(value: float, burst: object) -> str | None:
        before = None if history.continues(burst) else Snapshot(Model(gain["K"]), Model(0), [], 0, None, None, [], [])
        gain["K"] = value
        return history.push(before, book(), burst)

    history = EditHistory()
    assert edit(2.0, None) == "K: 1 -> 2"
    history.end_burst()
    assert edit(3.0, "drag") == "K: 2 -> 3"
    assert edit(2.0, "drag") is None  # back at the drag's start
    assert edit(4.0, "drag") == "K: 2 -> 4"
    assert [text for text, _ in history.undo_stack] == ["K: 1 -> 2", "K: 2 -> 4"]

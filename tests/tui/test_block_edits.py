"""Every row of the Plant tab is editable in the one-line form it shows."""

from __future__ import annotations

import numpy as np
import pytest

from sessions.errors import SessionError
from sessions.store import load_session
from tests.tui.conftest import EXAMPLES
from tests.tui.test_app import edit_row, synchronous
from tui.state.edits import plant_edit
from tui.state.plant_rows import plant_rows
from tui.state.workbench import Workbench

ALL = sorted(p.name for p in EXAMPLES.glob("*.json"))


@pytest.mark.parametrize("name", ALL)
def test_every_plant_row_reads_back_its_own_text(workdir, name):
    """Each row's edit text passes its own check, and applying it unchanged keeps the model."""
    bench = Workbench(load_session(workdir / name))
    for cells, ref in plant_rows(bench.session.model.problem):
        edit = plant_edit(bench, ref)
        assert edit is not None, f"{name}: row {cells[1]} has no edit"
        assert edit.check(edit.text) is None, (name, cells[1], edit.text, edit.check(edit.text))
        before = bench.session.model.problem.model_dump()
        edit.apply(edit.text)
        assert bench.session.model.problem.model_dump() == before, (name, cells[1])


def _plant_ref(bench):
    return next(ref for cells, ref in plant_rows(bench.session.model.problem) if cells[1] == "plant")


def test_a_factored_block_is_edited_renamed_and_rewired_in_one_line(workdir):
    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    ref = _plant_ref(bench)
    edit = plant_edit(bench, ref)
    assert edit.text == "plant u y factored: gain 16000; s^-1; poles (s+8) (s+20)"
    gh_before = bench.view().loop_curve().gh
    edit.apply("plant u y factored: gain 8000; s^-1; poles (s+8) (s+20)")
    assert np.allclose(bench.view().loop_curve().gh, gh_before / 2, rtol=1e-13)
    edit = plant_edit(bench, ref)
    edit.apply("plant u y 16000/(s*(s+8)*(s+20))")  # the expression it equals
    assert bench.session.model.problem.conditions[0].plant.blocks[ref[-1]].transfer.kind == "expression"
    assert np.allclose(bench.view().loop_curve().gh, gh_before, rtol=1e-12)
    assert "factors are" in plant_edit(bench, ref).check("plant u y factored: gain 1; poles (s+)")
    with pytest.raises(SessionError):  # re-wired to a signal nothing reads: refused, kept
        plant_edit(bench, ref).apply("plant u nowhere 1/s")
    assert bench.session.model.problem.conditions[0].plant.blocks[ref[-1]].output == "y"
    plant_edit(bench, ref).apply("G u y 16000/(s*(s+8)*(s+20))")
    assert bench.session.model.problem.conditions[0].plant.blocks[ref[-1]].name == "G"


def test_cascade_transfers_and_channel_compensators_are_edited(workdir):
    bench = Workbench(load_session(workdir / "seidel_inlet_pi.json"))
    rows = plant_rows(bench.session.model.problem)
    h1 = next(ref for cells, ref in rows if cells[1] == "H1")
    edit = plant_edit(bench, h1)
    assert edit.text == "controller: gain b1; s^-1; zero b21"
    edit.apply("controller: gain b1; s^-1; zero b21; pole 5000")  # the PI becomes seidel_inlet_pid's H1
    assert bench.session.model.problem.conditions[0].plant.h1.factors[-1].kind == "pole"
    ga = next(ref for cells, ref in rows if cells[1] == "GA")
    edit = plant_edit(bench, ga)
    assert edit.text.endswith("polar hz gain 36.9")
    edit.apply(edit.text.replace("gain 36.9", "gain 18.45"))
    assert bench.session.model.problem.conditions[0].plant.ga.table.gain == 18.45
    bench = Workbench(load_session(workdir / "cip_dual_channel.json"))
    rows = plant_rows(bench.session.model.problem)
    cells, ref = next((c, r) for c, r in rows if c[4] == "compensator")
    edit = plant_edit(bench, ref)
    assert edit.text.startswith("num ") and "; den " in edit.text
    assert "coefficient" in edit.check("num 1, x y; den 1")


@synchronous
async def test_the_factored_plant_opens_its_dialog_from_the_plant_tab(workdir):
    from tui.app import LoopcraftApp

    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        bench = app.bench
        index = next(i for i, (cells, _) in enumerate(plant_rows(bench.session.model.problem)) if cells[1] == "plant")
        await edit_row(app, pilot, "2", "blocks", index)
        field = app.screen.query_one("#value")
        assert field.value == "plant u y factored: gain 16000; s^-1; poles (s+8) (s+20)"
        field.value = "plant u y factored: gain 1000; s^-1; poles (s+8) (s+20)"
        await pilot.press("enter")
        await pilot.pause()
        await pilot.pause()
        assert app.bench.session.model.problem.conditions[0].plant.blocks[index].transfer.gain == 1000


@synchronous
async def test_a_refused_edit_keeps_the_typed_text_and_an_unknown_name_is_flagged_while_typing(workdir):
    from tui.app import LoopcraftApp
    from tui.screens.dialogs import EditDialog

    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        await edit_row(app, pilot, "2", "blocks", 1)
        field = app.screen.query_one("#value")
        field.value = "plant u y 16000/(s*(s+p9)*(s+20))"
        await pilot.pause()
        assert "unknown name 'p9'" in str(app.screen.query_one("#error").render())
        field.value = "plant u nowhere 16000/(s*(s+8)*(s+20))"  # reads, but the diagram does not build
        await pilot.press("enter")
        await pilot.pause()
        await pilot.pause()
        assert isinstance(app.screen, EditDialog)
        assert app.screen.query_one("#value").value == "plant u nowhere 16000/(s*(s+8)*(s+20))"
        assert "not applied" in str(app.screen.query_one("#error").render())
        await pilot.press("escape")
        await pilot.pause()
        assert app.bench.session.model.problem.conditions[0].plant.blocks[1].output == "y"
        assert app.screen.query_one("#blocks").cursor_row == 1  # the cursor stays on the edited row

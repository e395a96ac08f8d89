"""The Plant tab's grid of a matrix plant (tui.state.matrix_grid): headers, one row per
equation, each cell's entry index; pure data, no Textual."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from sessions.format.schema import MatrixModel
from sessions.store import load_session
from tui.state.matrix_grid import matrix_grid

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _plant(entries: list[tuple[int, int, str]], **extra) -> MatrixModel:
    return MatrixModel(
        format="matrix",
        signals=["e", "u", "y"],
        forcing_row=1,
        input_name="r",
        entries=[{"row": r, "col": c, "expression": x} for r, c, x in entries],
        **extra,
    )


def test_rows_are_equations_and_cells_name_their_entries():
    """e + y = r, u = C e, y = G u (report 003's chapter-1 loop in matrix form)."""
    plant = _plant(
        [(1, 1, "1"), (1, 3, "1"), (2, 2, "1"), (2, 1, "-K/(1+T*s)"), (3, 3, "1"), (3, 2, "-16000/(s*(s+8)*(s+20))")],
        forcing="2",
    )
    headers, rows = matrix_grid(plant)
    assert headers == ["e", "u", "y", "forcing"]
    assert [label for label, _ in rows] == ["1 e", "2 u", "3 y"]
    assert rows[0][1] == [("1", 0), ("", None), ("1", 1), ("2", None)]
    assert rows[1][1] == [("-K/(1+T*s)", 3), ("1", 2), ("", None), ("", None)]
    assert rows[2][1] == [("", None), ("-16000/(s*(s+8)*(s+20))", 5), ("1", 4), ("", None)]


def test_a_cell_given_twice_shows_the_last_entry_as_the_build_reads_it():
    plant = _plant([(1, 1, "1"), (2, 2, "1"), (3, 3, "1"), (3, 2, "-1/s"), (3, 2, "-2/s")])
    _, rows = matrix_grid(plant)
    assert rows[2][1][1] == ("-2/s", 4)
    assert rows[0][1][3] == ("1", None)  # the default forcing, in the forcing row only
    assert [cells[3] for _, cells in rows[1:]] == [("", None), ("", None)]


def test_the_launch_vehicle_shows_every_entry_once():
    session = load_session(EXAMPLES / "coebra_launch_vehicle_matrix.json")
    for condition in session.model.problem.conditions:
        plant = condition.plant
        headers, rows = matrix_grid(plant)
        assert headers[:-1] == plant.signals and len(rows) == len(plant.signals) == 24
        shown = [
            (i, j, text, k)
            for i, (_, cells) in enumerate(rows, start=1)
            for j, (text, k) in enumerate(cells[:-1], start=1)
            if k is not None
        ]
        assert sorted(k for *_, k in shown) == list(range(len(plant.entries)))
        for i, j, text, k in shown:
            e = plant.entries[k]
            assert (e.row, e.col, e.expression) == (i, j, text)
        assert all(text == "" for _, cells in rows for text, k in cells[:-1] if k is None)
        assert [cells[-1][0] for _, cells in rows] == ["1"] + [""] * 23
        assert rows[22][0] == "23 dc" and rows[22][1][21] == ("WF^2/(s^2+2*ZF*WF*s+WF^2)", 60)


def test_the_module_imports_no_textual():
    code = "import sys, tui.state.matrix_grid; sys.exit('textual' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], cwd=EXAMPLES.parents[1], timeout=60).returncode == 0


@pytest.mark.long
def test_the_plant_tab_edits_the_matrix_grid_in_place(workdir):
    import asyncio

    from tui.app import LoopcraftApp

    async def run() -> None:
        app = LoopcraftApp(workdir / "coebra_launch_vehicle_matrix.json")
        async with app.run_test(size=(120, 40)) as pilot:
            await pilot.pause()
            await app.workers.wait_for_complete()
            await pilot.press("2")
            grid = app.screen.query_one("#matrix-grid")
            assert grid.display and grid.row_count == len(app.bench.session.model.problem.conditions[0].plant.signals)
            grid.focus()
            grid.move_cursor(row=0, column=1)  # a[1,1]
            await pilot.press("e")
            await pilot.pause()
            entries = app.bench.session.model.problem.conditions[0].plant.entries
            k = next(i for i, e in enumerate(entries) if (e.row, e.col) == (1, 1))
            assert app.screen.query_one("#value").value == entries[k].expression
            await pilot.press("escape")
            empty = next(j for j, index in enumerate(grid.cells[0][:-1]) if index is None)
            grid.move_cursor(row=0, column=empty + 1)
            await pilot.press("e")
            await pilot.pause()
            app.screen.query_one("#value").value = "0"
            await pilot.press("enter")
            await pilot.pause()
            await pilot.pause()
            entries = app.bench.session.model.problem.conditions[0].plant.entries
            assert any((e.row, e.col, e.expression) == (1, empty + 1, "0") for e in entries)
            assert str(grid.get_cell_at(grid.cursor_coordinate)) == "0"

    asyncio.run(run())

"""ctrl+n offers every kind of new session and each opens as an untitled session."""

from __future__ import annotations

import pytest

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp


async def _type(pilot, text: str) -> None:
    for ch in text:
        await pilot.press(ch)
    await pilot.press("enter")
    await pilot.pause()


@pytest.mark.long
@synchronous
async def test_every_kind_of_new_session_opens(workdir):
    (workdir / "plant.csv").write_text("hz,mag,deg\n0.1,10,-90\n1,1,-120\n10,0.1,-170\n")
    app = LoopcraftApp(workdir / "coebra_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        kinds = {
            "unity": ["10/(s+1)", None],
            "two-loops": ["10/(s+1)", None, "1/s", None],
            "table": [str(workdir / "plant.csv"), "hz,mag,deg polar hz 1", None],
            "matrix": ["1/(s*(s+2))", None],
            "dae": [],
            "digital": ["0.5", "exp(-0.1*s)/(s*(s+2))", None],
        }
        for index, (kind, answers) in enumerate(kinds.items()):
            await pilot.press("ctrl+n")
            await pilot.pause()
            if app.screen.__class__.__name__ == "ConfirmDialog":  # unsaved: asked first
                await pilot.press("y")
                await pilot.pause()
            for _ in range(index):
                await pilot.press("down")
            await pilot.press("enter")
            await pilot.pause()
            for answer in answers:
                if answer is None:
                    await pilot.press("enter")  # the first structure: lead
                    await pilot.pause()
                else:
                    await _type(pilot, answer)
            await settle(app, pilot)
            session = app.bench.session
            assert session.path.name.startswith("untitled-"), kind
            assert app.bench.iteration == 0 and app.bench.dirty, kind
            formats = {c.plant.format for c in session.model.problem.conditions}
            expected = {
                "unity": {"diagram"},
                "two-loops": {"diagram"},
                "table": {"diagram"},
                "matrix": {"matrix"},
                "dae": set(),
                "digital": {"diagram"},
            }[kind]
            assert formats == expected, (kind, formats)
            if kind == "table":
                assert (session.path.parent / "plant.csv").exists()
            if kind == "digital":  # a loop in z, the plant held (zoh) with its delay
                condition = session.model.problem.conditions[0]
                assert (condition.variable, condition.sample_time) == ("z", 0.5)
                held = condition.plant.blocks[1].transfer
                assert (held.kind, held.method, held.delay) == ("discretized", "zoh", 0.1)


def test_a_csv_preview_of_a_fifo_or_a_huge_file_is_refused_not_waited_on(tmp_path):
    import os

    import pytest

    from tui.state.field_edits import csv_preview

    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match="pipe.csv"):
        csv_preview(fifo)
    table = tmp_path / "t.csv"
    table.write_text("# a comment\nhz,mag,deg\n1,2,3\n")
    assert csv_preview(table) == (["hz", "mag", "deg"], "hz,mag,deg\n1,2,3")


def test_the_import_line_is_guessed_from_the_columns_and_rows():
    """Issue 37, section 5: a dB column (negative values, or a dB name) is guessed 'db', not
    read as a linear magnitude; real/imag names are 'cartesian'; a Hz name sets the unit."""
    from tui.state.field_edits import guessed_table_line

    assert guessed_table_line(["hz", "mag", "deg"], "hz,mag,deg\n0.1,10,-90") == "hz,mag,deg polar hz 1"
    assert (
        guessed_table_line(["w", "gain", "phase"], "w,gain,phase\n0.1,20,-90\n1,-3,-120") == "w,gain,phase db rad/s 1"
    )
    assert guessed_table_line(["f_hz", "mag_db", "ph"], "f_hz,mag_db,ph\n1,3,-90") == "f_hz,mag_db,ph db hz 1"
    assert guessed_table_line(["w", "re", "im"], "w,re,im\n1,-3,-1") == "w,re,im cartesian rad/s 1"

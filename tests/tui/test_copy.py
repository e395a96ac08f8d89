"""y copies a table row or the tableau, Y the current design, to the clipboard."""

from __future__ import annotations

import numpy as np
import pytest

from engine.model.expressions import Expression
from tests.tui.test_app import select_row, settle, synchronous
from tui.app import LoopcraftApp
from tui.state.clipboard import with_values


def test_values_are_put_in_place_of_parameter_names():
    assert with_values("K*(s+z1)/(s+z10)", {"K": 2.0, "z1": -0.5, "z10": 3.0}) == "2.0*(s+(-0.5))/(s+3.0)"


@pytest.mark.long
@synchronous
async def test_y_copies_the_row_or_the_tableau_and_Y_the_design(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        await pilot.press("y")
        assert app.clipboard.startswith(app.screen.query_one("#tableau").text.plain[:20])
        await select_row(app, pilot, "2", "parameters", 0)
        await pilot.press("y")
        assert app.clipboard.split("\t")[0] == "z1"
        await pilot.press("Y")
        line = next(t for t in app.clipboard.splitlines() if t.startswith("compensator = "))
        copied = Expression(line.removeprefix("compensator = "), "s")
        values = app.bench.records[-1].parameters
        original = Expression("(s+z1)*(s+z2)/((s+p1)*(s+p2))", "s")
        s = 1j * np.logspace(-2, 3, 50)
        assert np.allclose(
            copied.evaluate(s, {}, with_grad=False).value,
            original.evaluate(s, values, with_grad=False).value,
            rtol=1e-14,
        )

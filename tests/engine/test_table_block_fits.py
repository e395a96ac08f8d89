"""A loop with a tabulated block is evaluated off the table through the network with the table's own fit
in its place (`engine.margins.search.fitted_loop`): fitted once per table, not once per design, and
checked against the table's loop values, an independent closed form and python-control's margins."""

from __future__ import annotations

from pathlib import Path

import control as ct
import numpy as np
import pytest

import engine.loop.fit_cache as fit_cache
from engine.loop.responses import loop_model
from engine.margins.search import _whole_loop_fit, fitted_loop, margins
from engine.model.blocks import ExpressionTransfer, FrequencyTable, TabulatedTransfer
from engine.model.network import Block, Junction, block_diagram
from sessions.store import load_session

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def test_the_launch_vehicle_fits_its_table_once_over_several_designs(monkeypatch):
    """Before, every design refitted the whole loop (one AAA fit per design: 0.4-0.9 s each)."""
    problem = load_session(EXAMPLES / "cip_launch_vehicle.json").problem
    condition = problem.conditions[0]
    tables = sum(isinstance(e.transfer, TabulatedTransfer) for e in condition.network.entries)
    start = problem.condition_values(0)
    fits = []
    made = fit_cache.fit_response
    monkeypatch.setattr(fit_cache, "fit_response", lambda *a, **k: fits.append(1) or made(*a, **k))
    for step in range(4):
        values = {name: value * (1 + 0.0137 * (step + 1)) for name, value in start.items()}
        loop = loop_model(condition.network, condition.break_at, problem.grid.omega, values)
        found = margins(loop)
        assert found.method == "fitted" and "each table's rational fit in its place" in found.notes[0]
    assert tables >= 1 and len(fits) <= tables
    whole = _whole_loop_fit(loop)  # the way before: the same margins within the two fits' residuals
    before = margins(whole.model)
    tolerance = 10 * (found.residual + whole.residual)
    for kind in ("gain", "phase", "stability"):
        now, then = getattr(found, kind), getattr(before, kind)
        assert len(now) == len(then) > 0
        np.testing.assert_allclose([m.value for m in now], [m.value for m in then], rtol=tolerance)


W = np.geomspace(0.05, 50.0, 300)
PLANT = "10/((s+1)*(s+5))"
COMPENSATOR = "K*(s+2)/(s+20)"


def _inner_loop(plant):
    """e = r - y, u = C e, y = P (u - 0.5 y): the table inside a feedback loop (GH at e is C P/(1 + 0.5 P))."""
    return block_diagram(
        [
            Block("C", "e", "u", ExpressionTransfer(COMPENSATOR)),
            Block("P", "v", "y", plant),
            Block("H", "y", "h", ExpressionTransfer("0.5")),
        ],
        [Junction("sum", "e", ((1.0, "r"), (-1.0, "y"))), Junction("inner", "v", ((1.0, "u"), (-1.0, "h")))],
        ["r"],
    )


def _closed_form(w, K):
    s = 1j * w
    p = 10 / ((s + 1) * (s + 5))
    return K * (s + 2) / (s + 20) * p / (1 + 0.5 * p)


def test_the_loop_through_the_tables_fit_is_the_table_between_its_points():
    s = 1j * W
    table = TabulatedTransfer(FrequencyTable(W, 10 / ((s + 1) * (s + 5)), "plant"))
    values = {"K": 30.0}
    loop = loop_model(_inner_loop(table), "e", W, values)
    through, whole = fitted_loop(loop), _whole_loop_fit(loop)
    assert through is not None and whole is not None and "in its place" in through.how
    on_table = np.abs(through.model.evaluate(W)[0] - loop.gh) / np.abs(loop.gh)
    assert np.max(on_table) <= through.residual < 1e-8
    between = np.sqrt(W[1:] * W[:-1])
    exact = _closed_form(between, values["K"])
    off = np.abs(through.model.evaluate(between)[0] - exact) / np.abs(exact)
    assert np.max(off) < 1e-6
    whole_off = np.abs(through.model.evaluate(between)[0] - whole.model.evaluate(between)[0]) / np.abs(exact)
    assert np.max(whole_off) < 1e-6
    tf = ct.tf([1, 2], [1, 20]) * values["K"] * ct.feedback(ct.tf([10], [1, 6, 5]), 0.5)
    _, _, _, wg, wp, _ = ct.stability_margins(tf, returnall=True)
    found = margins(loop)
    inside = lambda ws: np.sort([w for w in ws if W[0] < w < W[-1]])  # noqa: E731
    np.testing.assert_allclose([m.frequency for m in found.phase], inside(wp), rtol=1e-6)
    np.testing.assert_allclose([m.frequency for m in found.gain if m.frequency > 0], inside(wg), rtol=1e-6)


@pytest.mark.parametrize("points", [40, 400])
def test_a_design_changes_the_loop_not_the_tables_fit(points):
    """Two designs of one table: the same fit serves both and each matches its own closed form."""
    w = np.geomspace(0.05, 50.0, points)
    s = 1j * w
    table = TabulatedTransfer(FrequencyTable(w, 10 / ((s + 1) * (s + 5)), "plant"))
    network = _inner_loop(table)
    between = np.sqrt(w[1:] * w[:-1])
    for K in (3.0, 300.0):
        through = fitted_loop(loop_model(network, "e", w, {"K": K}))
        assert through is not None and "in its place" in through.how
        exact = _closed_form(between, K)
        assert np.max(np.abs(through.model.evaluate(between)[0] - exact) / np.abs(exact)) < 1e-5


def test_a_designs_loop_through_its_tables_fits_is_made_once(monkeypatch):
    """Its margins, its peaks and a gain solve each built the loop through the fits again (2-3
    times a design); now once per design: a loop of other values makes its own."""
    import engine.margins.search as search
    from engine.analysis import margins_with_peaks
    from engine.design.gain_solves import gain_for_crossover

    s = 1j * W
    network = _inner_loop(TabulatedTransfer(FrequencyTable(W, 10 / ((s + 1) * (s + 5)), "plant")))
    built = []
    made = search.loop_model
    monkeypatch.setattr(search, "loop_model", lambda *a, **k: built.append(a[3]) or made(*a, **k))
    found, peaks = margins_with_peaks(loop_model(network, "e", W, {"K": 31.0}), 0.0)
    solved = gain_for_crossover(loop_model(network, "e", W, {"K": 31.0}), 2.0)
    again = fitted_loop(loop_model(network, "e", W, {"K": 31.0}))
    assert (
        "each table's rational fit" in solved.note
        and found.method == "fitted"
        and peaks is not None
        and again is not None
    )
    assert len(built) == 1
    other = fitted_loop(loop_model(network, "e", W, {"K": 32.0}))
    assert len(built) == 2 and other is not again
    np.testing.assert_allclose(other.model.evaluate(W)[0], _closed_form(W, 32.0), rtol=1e-6)


def test_the_tableau_and_the_plots_solve_a_tabulated_designs_loop_once(monkeypatch):
    """cip's grid rule on the launch vehicle's tables read the loop from a solve of its own, the
    plots' loop model from another (two network solves a nudge); now the design's loop model's
    response serves both, the same values."""
    import engine.loop.responses as responses
    from engine.cip.requirements import detect

    problem = load_session(EXAMPLES / "cip_launch_vehicle.json").problem
    condition, x = problem.conditions[0], problem.vector() * 1.003
    values = problem.condition_values(0, x)
    alone = responses.open_loop(condition.network, condition.break_at, problem.grid.omega, values, False).value
    solved = []
    solve = responses.solve
    monkeypatch.setattr(responses, "solve", lambda *a, **k: solved.append(1) or solve(*a, **k))
    detect(problem, x, "auto")
    plotted = loop_model(condition.network, condition.break_at, problem.grid.omega, values)
    assert len(solved) == 1 and plotted.source is not None  # (the plots' loop keeps its network for the fits)
    np.testing.assert_array_equal(plotted.gh, alone)


def test_a_new_design_evaluates_the_tables_fit_only_where_none_did_before(monkeypatch):
    """The table's fit is the same on every design, yet each design's margins evaluated it again at the
    table's points (the loop's residual) and on the detection grid (the launch vehicle: about 2 500
    frequencies a nudge, 60-100 ms of a plots worker's 100); now a frequency asked once is kept
    (`engine.numerics.point_memo`), and the margins are the same bit for bit."""
    import engine.numerics.rational_fit as rational_fit
    from engine.derived import Derived

    s = 1j * W
    table = TabulatedTransfer(FrequencyTable(W, 10 / ((s + 1) * (s + 5)), "plant"))

    def found(K: float) -> list[tuple]:  # (a network of its own: its designs keep no margins found before)
        m = margins(loop_model(_inner_loop(table), "e", W, {"K": K}))
        assert m.method == "fitted"
        return [(x.kind, x.frequency, x.value) for x in (*m.gain, *m.phase, *m.stability)]

    monkeypatch.setattr(fit_cache, "_FITS", Derived(fit_cache.KEPT))  # a fresh fit: nothing asked of it yet
    alone = found(32.0)
    monkeypatch.setattr(fit_cache, "_FITS", Derived(fit_cache.KEPT))
    found(31.0)
    rows = []
    evaluate = rational_fit._bary
    monkeypatch.setattr(rational_fit, "_bary", lambda z, *a, **k: rows.append(z.size) or evaluate(z, *a, **k))
    after = found(32.0)
    assert after == alone and len(alone) >= 2
    assert 0 < sum(rows) < W.size  # the refinement's new frequencies only (before: the table's 300 and the grid)

"""History shows every view of the selected iteration's design (S/T, pole-zero map,
Nichols, root locus, ...), against the marked iteration; checked against the engine
and independent computations at that iteration's parameters."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from engine.loop.responses import loop_model
from engine.margins.peaks import sensitivity_peak
from tests.tui.test_app import select_row, settle, synchronous
from tui.app import LoopcraftApp

# lead_sensitivity_peak: L = 10 (1 + T1 s) / ((1 + T2 s) s (s + 1) (s + 5)), unity feedback


def _loop(s, T1, T2):
    return 10 * (1 + T1 * s) / ((1 + T2 * s) * s * (s + 1) * (s + 5))


def _closed_loop_poles(T1, T2) -> np.ndarray:
    den = np.polymul([T2, 1], np.polymul([1, 0], np.polymul([1, 1], [1, 5])))
    return np.sort_complex(np.roots(np.polyadd(den, [10 * T1, 10])))


def _points(series) -> np.ndarray:
    return np.sort_complex(np.array(series.x) + 1j * np.array(series.y))


async def _history(app, pilot, steps: int, row: int) -> None:
    """Step, then show History with a row selected and everything drawn."""
    await settle(app, pilot)
    for _ in range(steps):
        await pilot.press("s")
        await settle(app, pilot)
    await select_row(app, pilot, "4", "history-table", row)
    await settle(app, pilot)


async def _view(app, pilot, kind: str):
    """Press p until the History plot shows ``kind``; its figure, drawn."""
    pane = app.screen.query_one("#history-pane")
    for _ in range(len(pane.views())):
        if pane.kind == kind:
            break
        await pilot.press("p")
        await settle(app, pilot)
    await settle(app, pilot)
    assert pane.kind == kind
    return app.screen.query_one("#history-plot").figure


def _parameters(app, iteration: int) -> dict[str, float]:
    return app.bench.session.problem.condition_values(0, named=app.bench.records[iteration - 1].parameters)


@pytest.mark.long
@synchronous
async def test_the_s_t_view_is_the_selected_iterations(workdir):
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await _history(app, pilot, 3, 1)
        figure = await _view(app, pilot, "closed-loop")
        p = _parameters(app, 1)
        assert p == {"T1": 1.2, "T2": 0.8}
        c = app.bench.session.problem.conditions[0]
        peak = sensitivity_peak(loop_model(c.network, c.break_at, app.bench.session.problem.grid.omega, p))
        marker = next(s for s in figure.series if s.scatter and s.color == "blue")  # Ms of iteration 1
        assert marker.y[0] == pytest.approx(peak.db, abs=1e-9)
        assert figure.title.startswith("S/T: iteration 1") and f"Ms {peak.value:.4g}" in figure.title
        w = np.logspace(-3, 3, 600001)
        assert peak.value == pytest.approx(np.abs(1 / (1 + _loop(1j * w, **p))).max(), rel=1e-6)
        current = next(s for s in figure.series if s.label.startswith("current: Ms"))  # gray, one entry
        ms_now = np.abs(1 / (1 + _loop(1j * w, **_parameters(app, 3)))).max()
        assert f"Ms {ms_now:.4g}" in current.label and abs(ms_now - peak.value) > 0.01


@pytest.mark.long
@synchronous
async def test_marked_pole_zero_maps_nichols_and_the_cursor(workdir):
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await _history(app, pilot, 3, 1)
        await pilot.press("m")  # iteration 1 marked
        app.screen.query_one("#history-table").move_cursor(row=3)
        await settle(app, pilot)
        figure = await _view(app, pilot, "poles")
        assert figure.title == "Poles and zeros: iteration 3 vs marked 1"
        mine = next(s for s in figure.series if s.label == "closed-loop poles")
        marked = next(s for s in figure.series if s.label == "iteration 1 (marked) closed loop")
        assert (mine.color, marked.color) == ("red", "gray")
        assert np.allclose(_points(mine), _closed_loop_poles(**_parameters(app, 3)), rtol=1e-9)
        assert np.allclose(_points(marked), _closed_loop_poles(**_parameters(app, 1)), rtol=1e-9)
        plot = app.screen.query_one("#history-plot")
        plot.focus()
        await pilot.press("right")  # the cursor: the least damped pole first
        await pilot.pause()
        poles = [p for p in _closed_loop_poles(**_parameters(app, 3)) if p.imag >= 0]
        pole = min(poles, key=lambda p: -p.real / abs(p))
        words = plot.shown.title.split()
        assert complex(words[1].replace("j", "") + "j") == pytest.approx(pole, rel=1e-4)
        assert float(words[3]) == pytest.approx(-pole.real / abs(pole), rel=1e-3)
        assert float(words[5]) == pytest.approx(abs(pole), rel=1e-4)
        await pilot.press("plus", "l")  # zoom about the cursor, pan
        await pilot.pause()
        x0, x1, _, _ = plot.navigation.box
        assert x0 > min(plot.figure.xlim) and plot.shown.xlim == (x0, x1)
        figure = await _view(app, pilot, "nichols")  # p from the focused plot: another view
        assert plot.navigation.box is None and plot.navigation.cursor is None
        curves = {s.label: s for s in figure.series if s.label.startswith("iteration")}
        assert set(curves) == {"iteration 3", "iteration 1 (marked)"}
        for label, iteration in (("iteration 3", 3), ("iteration 1 (marked)", 1)):
            s = curves[label]
            i = len(s.x) // 2
            omega = app.bench.session.problem.grid.omega
            db = 20 * np.log10(np.abs(_loop(1j * omega, **_parameters(app, iteration))))
            assert np.min(np.abs(db - s.y[i])) < 1e-9  # a point of that iteration's |L|


@synchronous
async def test_the_locus_of_an_earlier_iteration_is_computed_off_the_ui_thread(workdir, monkeypatch):
    import tui.figures.history as history_figures

    threads = []
    original = history_figures.locus_figure

    def recorded(*args, **kwargs):
        threads.append(threading.current_thread())
        return original(*args, **kwargs)

    monkeypatch.setattr(history_figures, "locus_figure", recorded)
    app = LoopcraftApp(workdir / "lead_sensitivity_peak.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await _history(app, pilot, 3, 2)
        await pilot.press("L")  # in History: the History plot's locus
        await pilot.pause()
        app.screen.dismiss("gain")
        await settle(app, pilot)
        await settle(app, pilot)
        pane = app.screen.query_one("#history-pane")
        figure = app.screen.query_one("#history-plot").figure
        assert pane.kind == "locus" and app.screen.query_one("#tabs").active == "history"
        assert figure.title.startswith("Root locus in the loop gain: iteration 2")
        assert threads and all(t is not threading.main_thread() for t in threads)
        current = next(s for s in figure.series if s.label == "k = 1 (iteration 2)")
        assert np.allclose(_points(current), _closed_loop_poles(**_parameters(app, 2)), rtol=1e-6)


@synchronous
async def test_keys_that_cannot_act_are_disabled(workdir):
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")  # tabulated: no poles, locus or step
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        pane = app.screen.query_one("#history-pane")
        await pilot.press("4")
        await settle(app, pilot)
        assert pane.check_action("mark", ()) is None  # no iteration to compare yet
        assert pane.views() == ["nyquist", "bode", "phase", "nichols", "closed-loop"]
        assert app.screen.check_action("locus_parameter", ()) is None
        await pilot.press("L")
        await pilot.pause()
        assert app.screen is app.screen_stack[-1] and type(app.screen).__name__ == "MainScreen"
    app = LoopcraftApp(workdir / "projection_integrator.json")  # no loop: no views of a design
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("4")
        await settle(app, pilot)
        pane = app.screen.query_one("#history-pane")
        assert pane.views() == [] and pane.check_action("next_view", ()) is None
        assert app.screen.check_action("next_plot", ()) is None
        assert "no views" in app.screen.query_one("#history-plot").figure.empty_message


@pytest.mark.long
@synchronous
async def test_undo_and_the_conditions_key_redraw_the_history_plot(workdir):
    app = LoopcraftApp(workdir / "coebra_launch_vehicle.json")  # three flight conditions
    async with app.run_test(size=(120, 40)) as pilot:
        await _history(app, pilot, 2, 2)
        figure = await _view(app, pilot, "closed-loop")
        assert figure.title.startswith("S/T: iteration 2")
        assert {s.label.split()[0] for s in figure.series if s.label.endswith("|S|")} == {
            "switch-in",
            "max-q",
            "switch-out",
        }
        await pilot.press("z")  # iteration 2 is gone: the row moves up
        await settle(app, pilot)
        assert app.bench.iteration == 1
        assert not [n for n in app._notifications if n.severity == "error"]
        assert app.screen.query_one("#history-plot").figure.title.startswith("S/T: iteration 1")
        await pilot.press("v")  # one condition, with the current design
        await settle(app, pilot)
        figure = app.screen.query_one("#history-plot").figure
        assert figure.title.startswith("S/T: iteration 1 (switch-in)") and "error" not in figure.empty_message

"""The step plot: chosen signals, the current design's horizon and scale, and its marks."""

from __future__ import annotations

import control as ct
import numpy as np

from engine.closed_loop.step_response import StepSetup
from sessions.store import load_session
from tests.tui.test_app import settle, synchronous
from tui.figures.lines import step_figure
from tui.state.step_view import parse_step_setup
from tui.state.workbench import Workbench


def test_the_marks_agree_with_python_control_step_info(workdir):
    """report 003's lag-lead loop: rise time, overshoot and settling time against control.step_info
    (same 10-90 % rise and 5 % settling definitions) on the same closed loop."""
    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    view = bench.view()
    name, traces, marks = view.step_plot()
    s = ct.tf("s")
    loop = (s + 1) * (s + 5) / ((s + 0.1) * (s + 50)) * 16000 / (s * (s + 8) * (s + 20))
    t = np.linspace(0, 60, 200001)
    info = ct.step_info(ct.feedback(loop, 1), T=t, SettlingTimeThreshold=0.05, RiseTimeLimits=(0.1, 0.9))
    assert abs(marks.overshoot_percent - info["Overshoot"]) < 0.05 * info["Overshoot"]
    assert abs(marks.rise_time - info["RiseTime"]) < 0.03 * info["RiseTime"]
    assert abs(marks.settling_time - info["SettlingTime"]) < 0.03 * info["SettlingTime"]
    fig = step_figure(name, traces, marks)
    assert "overshoot" in fig.title and "settles" in fig.title and any(s.label == "peak" for s in fig.series)


def test_signals_and_horizon_are_chosen_and_checked(workdir):
    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    ss = bench.view().step_loop()
    assert "unknown" not in str(parse_step_setup("", ss.inputs, ss.outputs))
    bench.step_setup = parse_step_setup("r u 3", ss.inputs, ss.outputs)
    t, y, name = bench.view().step_response()
    assert name == "u (step at r)" and t[-1] == 3.0
    for text, message in [("r nowhere", "not a signal"), ("q y", "not an input"), ("r y -1", "horizon")]:
        try:
            parse_step_setup(text, ss.inputs, ss.outputs)
        except ValueError as exc:
            assert message in str(exc)
        else:
            raise AssertionError(text)
    bench.step_setup = StepSetup()
    assert bench.view().step_response()[2] == "y (step at r)"


def test_the_axis_is_scaled_to_the_current_design_not_an_unstable_start(workdir):
    bench = Workbench(load_session(workdir / "coebra_lag_lead.json"))  # the start is unstable (PM -28.6 deg)
    for _ in range(8):
        bench.step()
    view = bench.view()
    name, traces, marks = view.step_plot()
    assert len(traces) == 2 and traces[1][3] == "reference"
    fig = step_figure(name, traces, marks)
    current = np.array(traces[0][1])
    low, high = fig.ylim
    assert low <= current.min() and current.max() <= high and high - low < 3 * (current.max() - current.min() + 0.1)
    assert traces[0][0][-1] == traces[1][0][-1]  # one horizon: the current design's


@synchronous
async def test_t_opens_the_step_setup_and_the_plot_follows(workdir):
    from tui.app import LoopcraftApp
    from tui.screens.dialogs import EditDialog

    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("t")
        await pilot.pause()
        assert isinstance(app.screen, EditDialog) and app.screen.query_one("#value").value == "r y"
        app.screen.query_one("#value").value = "r e 2"
        await pilot.press("enter")
        await settle(app, pilot)
        assert app.bench.step_setup == StepSetup("r", "e", 2.0)
        assert app.bench.view().step_response()[2] == "e (step at r)"


def test_a_loop_with_delay_has_a_step_plot(tmp_path):
    """K exp(-s)/(s+1) (K = 1): the step plot draws its simulated response, marked (issue 52's delay case)."""
    import json

    from sessions.new.templates import new_session

    (tmp_path / "d.json").write_text(json.dumps(new_session("1/(s+1)*exp(-1*s)", "K")))
    session = load_session(tmp_path / "d.json")
    name, traces, marks = Workbench(session).view().step_plot()
    assert name == "y (step at r, simulated)" and traces and marks is not None
    assert abs(marks.peak_time - (2 + np.exp(-1))) < 1e-4 and abs(marks.final - 0.5) < 1e-12
    fig = step_figure(name, traces, marks)
    assert "overshoot 38.4 %" in fig.title


def test_a_delay_loops_step_signals_are_chosen(tmp_path):
    import json

    from sessions.new.templates import new_session

    (tmp_path / "d.json").write_text(json.dumps(new_session("1/(s+1)*exp(-1*s)", "K")))
    bench = Workbench(load_session(tmp_path / "d.json"))
    inputs, outputs = bench.view().step_signals()
    assert inputs == ("r",) and "e" in outputs and bench.view().step_loop() is None
    bench.step_setup = parse_step_setup("r e 5", inputs, outputs)
    t, y, name = bench.view().step_response()
    assert name == "e (step at r, simulated)" and abs(t[-1] - 5.0) < 1e-9
    assert y[0] == 1.0 and abs(y[-1] - 0.5) < 0.05  # e = r - y: 1 until the delay, then toward 1/2

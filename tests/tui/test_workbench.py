"""The workbench's model without widgets: the plot data against independent computations."""

from __future__ import annotations

import control as ct
import numpy as np

from sessions.store import load_session
from tui.workbench import Workbench


def test_step_response_matches_python_control(workdir):
    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    t, y, label = bench.step_response()
    s = ct.tf("s")
    loop = (s + 1) * (s + 5) / ((s + 0.1) * (s + 50)) * 16000 / (s * (s + 8) * (s + 20))
    _, expected = ct.step_response(ct.feedback(loop, 1), T=np.array(t))
    assert label.startswith("y") and np.allclose(y, expected, atol=1e-8)


def test_loop_curve_is_the_open_loop_and_undo_restores_parameters(workdir):
    bench = Workbench(load_session(workdir / "report003_lag_lead.json"))
    curve = bench.loop_curve()
    s = 1j * curve.omega
    expected = (s + 1) * (s + 5) / ((s + 0.1) * (s + 50)) * 16000 / (s * (s + 8) * (s + 20))
    assert np.allclose(curve.gh, expected, rtol=1e-12)
    bench2 = Workbench(load_session(workdir / "cip_launch_vehicle.json"))
    start = bench2.parameters()
    bench2.step()
    assert bench2.parameters() != start
    bench2.undo()
    assert bench2.parameters() == start and bench2.iteration == 0

"""The plots of a loop whose plant is a state-space block of order 40 (lightly damped
modes over five decades): the Bode magnitude, the open- and closed-loop poles and the
root locus are those of the same loop in python-control."""

from __future__ import annotations

import json

import control
import numpy as np

from sessions.new.templates import new_session
from sessions.store import load_session
from tests.engine.test_state_space_acceptance import random_model
from tui.figures.catalog import figures
from tui.figures.closed_loop import locus_figure
from tui.state.workbench import Workbench


def test_bode_poles_and_locus_of_a_state_space_plant(tmp_path):
    A, B, C, D = random_model(49)
    plant = {"kind": "state_space", "A": A.tolist(), "B": B[:, 0].tolist(), "C": C[0].tolist(), "D": float(D[0, 0])}
    (tmp_path / "s.json").write_text(json.dumps(new_session(plant, "gain")))  # K = 1
    view = Workbench(load_session(tmp_path / "s.json")).view()
    shown = figures(view, only={"bode-mag", "poles"})
    loop = control.ss(A, B, C, D)
    curve = next(s for s in shown["bode-mag"].series if s.label == "current")
    omega = 10 ** np.array(curve.x) if shown["bode-mag"].log_x else np.array(curve.x)
    assert np.allclose(curve.y, 20 * np.log10(np.abs(loop(1j * omega).ravel())), atol=1e-9)

    def roots(label: str, figure=shown["poles"]) -> np.ndarray:
        series = next(s for s in figure.series if s.label.startswith(label))
        return np.sort_complex(np.array(series.x) + 1j * np.array(series.y))

    assert np.allclose(roots("open-loop poles"), np.sort_complex(loop.poles()), rtol=1e-10)
    closed = np.sort_complex(control.feedback(loop, 1).poles())
    assert np.allclose(roots("closed-loop poles"), closed, rtol=1e-9)
    assert np.allclose(roots("k = 1", locus_figure(view)), closed, rtol=1e-9)

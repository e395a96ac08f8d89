"""Rendering the workbench's plots (issue 36): a 600-point Bode (magnitude and phase,
the current and the initial design, the margins and a requirement drawn) at its
120x40 canvases, drawn as the workbench draws it now against the drawing before the
issue (plotext's own legend inside the axes, ticks unspaced, no overlays) on the same
curves, interleaved."""

from __future__ import annotations

import tempfile
from dataclasses import replace
from pathlib import Path

from tests.bench.common import compared

THEME = "textual-dark"
CANVASES = {"bode-mag": (71, 17), "bode-phase": (71, 17)}  # the Bode plots' canvases at 120x40
POINTS = 600


def _figures() -> dict:
    """The Bode figures of the lag-lead example after one step, on a 600-point grid."""
    import shutil

    import numpy as np

    from engine.design.problem import Grid
    from sessions.store import load_session
    from tui.figures.catalog import figures
    from tui.state.workbench import Workbench

    example = Path(__file__).resolve().parents[2] / "sessions" / "examples" / "report003_lag_lead.json"
    folder = Path(tempfile.mkdtemp())
    shutil.copy2(example, folder / example.name)
    bench = Workbench(load_session(folder / example.name))
    bench.session.path = None
    bench.step()
    view = bench.view()
    omega = view.problem.grid.omega
    grid = Grid(np.geomspace(omega.min(), omega.max(), POINTS), view.problem.grid.unit)
    return figures(replace(view, problem=replace(view.problem, grid=grid)), set(CANVASES))


def _before(fig, width: int, height: int) -> str:
    """The drawing before issue 36: every labelled series in plotext's legend, plotext's
    ticks at the figure's decades, no overlay."""
    from textual_plotext.plot import Plot

    plot = Plot()
    plot.clear_figure()
    plot.title(fig.title)
    plot.xlabel(fig.xlabel)
    plot.ylabel(fig.ylabel)
    for s in fig.series:
        if s.label and " target: " in s.label or s.marker == "░":
            continue
        (plot.scatter if s.scatter else plot.plot)(
            s.x, s.y, marker="braille" if not s.scatter else s.marker, label=s.label or None, color=s.color or "blue"
        )
    if fig.xticks:
        plot.xticks(*fig.xticks)
    plot.plotsize(width, height)
    plot._set_size(width, height)
    plot.theme(THEME)
    return plot.build()


def bode_render(repeat: int) -> dict:
    """Both Bode plots drawn now against before, and the figure's size."""
    from tui.drawing.text_canvas import draw

    figs = _figures()
    before = {name: replace(fig) for name, fig in figs.items()}

    def ours(i: int = 0) -> None:
        for name, (w, h) in CANVASES.items():
            assert draw(figs[name], w, h, THEME) is not None

    def theirs(i: int = 0) -> None:
        for name, (w, h) in CANVASES.items():
            _before(before[name], w, h)

    points = len(figs["bode-mag"].series[0].x)
    return compared(ours, theirs, repeat, target=1.0, points=points, canvases=CANVASES)

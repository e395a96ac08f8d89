"""A point far outside a figure's axis limits (an iterate at 1e36 against a 4e13
bound) is drawn clipped: plotext draws lines point by point across the canvas,
and one such point exhausted memory in the workbench."""

from __future__ import annotations

import math

import pytest

from tui.drawing.text_canvas import near
from tui.figures.data import Figure, Series
from tui.widgets.plots import FigurePlot


def test_values_are_clipped_a_few_spans_about_the_limits():
    assert near([0.0, 1e36, -1e36, 0.5], (-1.0, 1.0)) == [0.0, 5.0, -5.0, 0.5]
    assert near([1e36], None) == [1e36]  # no limits: plotext scales to the data
    assert near([1e300, -1e300], None) == [1e150, -1e150]  # but never near the float limits


def test_a_far_excursion_beside_a_bounded_axis_draws_at_once():
    fig = Figure(title="bounded", ylim=(-1.0, 1.0))
    fig.series.append(Series([0.0, 1.0, 2.0], [0.0, 1e36, 0.0], "u"))
    canvas = (60, 20, "textual-dark")
    built = FigurePlot.prebuild(fig, canvas)
    assert built[1] is not None and built[0] == (canvas, (None, None)) and "bounded" in built[1].text.plain


def test_values_near_the_float_limits_draw():
    fig = Figure(title="huge")
    fig.series.append(Series([0.0, 1.0, 2.0], [0.0, 1.7e308, -1.7e308], "u"))
    assert FigurePlot.prebuild(fig, (60, 20, "textual-dark"))[1] is not None  # drawn, no OverflowError


def test_a_time_axis_over_an_overflowing_span_still_has_a_step():
    from tui.figures.trajectories import _step

    assert _step(float("inf"), 5) == 1.0 and _step(10.0, 5) == 2.0


def test_axis_ticks_are_round_numbers_inside_the_axis():
    from tui.figures.axes import nice_ticks

    for low, high in [(-107.0, 60.0), (-95.9, 4.4), (23.7, 40.9), (0.0013, 0.0041), (-3e-9, 7e-9), (1e5, 3.3e7)]:
        ticks, labels = nice_ticks(low, high)
        assert 2 <= len(ticks) <= 6 and all(low - 1e-12 * abs(high) <= t <= high + 1e-12 * abs(high) for t in ticks)
        steps = {round(b - a, 12) for a, b in zip(ticks, ticks[1:])}
        step = steps.pop()
        mantissa = step / 10 ** math.floor(math.log10(step))
        assert not steps and round(mantissa, 9) in (1.0, 2.0, 5.0), (low, high, ticks)
        assert all(float(label) == pytest.approx(t, rel=1e-9, abs=1e-15) for label, t in zip(labels, ticks))


@pytest.mark.long
@pytest.mark.parametrize("example", ["cip_dual_channel", "report003_lag_lead", "lead_sensitivity_peak"])
def test_zoom_pan_and_cursor_never_break_a_plot(example):
    """Issue 36, section 2 (in part): zoomed past a curve's samples, plotext's legend indexed
    the colours of points it had dropped (IndexError: 'cannot draw at this size' at the
    second to fifth '+').  Random zoom, pan and cursor moves on every figure, at three sizes."""
    import random
    from pathlib import Path

    from sessions.store import load_session
    from tui.figures.catalog import figures
    from tui.figures.navigation import Navigation
    from tui.state.workbench import Workbench

    path = Path(__file__).resolve().parents[2] / "sessions" / "examples" / f"{example}.json"
    view = Workbench(load_session(path)).view()
    rng = random.Random(example)
    for name, fig in figures(view).items():
        for canvas in ((118, 30, "textual-dark"), (78, 16, "textual-dark"), (50, 9, "textual-dark")):
            navigation = Navigation()
            for _ in range(12):
                move = rng.choice(["in", "in", "out", "pan", "cursor"])
                if move == "in":
                    navigation.zoom(fig, 1.5)
                elif move == "out":
                    navigation.zoom(fig, 1 / 1.5)
                elif move == "pan":
                    navigation.pan(fig, rng.choice([-0.25, 0.25]), rng.choice([-0.25, 0.0, 0.25]))
                else:
                    navigation.move(fig, rng.choice([-5, 1, 20]))
                assert FigurePlot.prebuild(navigation.applied(fig), canvas)[1] is not None, (name, canvas)


def _dots(plain: str) -> set[tuple[int, int]]:
    """The braille dots of a drawing, as (column, row) in dot units."""
    bits = [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (0, 3), (1, 3)]  # the Unicode dot order
    out = set()
    for row, line in enumerate(plain.split("\n")):
        for col, char in enumerate(line):
            code = ord(char) - 0x2800
            if 0 < code < 256:
                out |= {(2 * col + dx, 4 * row + dy) for k, (dx, dy) in enumerate(bits) if code >> k & 1}
    return out


@pytest.mark.parametrize("seed", range(6))
def test_a_thinned_line_is_drawn_within_a_dot_of_the_whole_line(seed):
    """Lines are thinned to what the canvas resolves (first, lowest, highest and last point
    of each pixel column's run) before plotext draws them: every dot of either drawing is
    within one dot of the other's."""
    import numpy as np

    import tui.drawing.text_canvas as canvas

    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(-2, 3, 2000)) if seed % 2 else np.linspace(-2, 3, 2000)
    y = np.cumsum(rng.normal(size=x.size)) * (1 + seed) + 5 * np.sin(3 * x)
    fig = Figure(title="thinned")
    fig.series.append(Series(x.tolist(), y.tolist(), "random walk"))
    thin = canvas.draw(fig, 70, 20, "textual-dark").text.plain
    original = canvas.thinned
    try:
        canvas.thinned = lambda x, y, span, columns: (x, y)
        whole = canvas.draw(fig, 70, 20, "textual-dark").text.plain
    finally:
        canvas.thinned = original
    a, b = _dots(thin), _dots(whole)
    near_b = {(c + i, r + j) for c, r in b for i in (-1, 0, 1) for j in (-1, 0, 1)}
    near_a = {(c + i, r + j) for c, r in a for i in (-1, 0, 1) for j in (-1, 0, 1)}
    assert a <= near_b and b <= near_a
    assert len(canvas.thinned(x.tolist(), y.tolist(), (-2.0, 3.0), 140)[0]) < 0.4 * x.size


def test_a_worker_s_drawing_in_a_held_cursor_reads_the_cursor_out():
    """A figure without its own probe drawn by a worker with the cursor held (`prebuild`): the
    cursor along its first curve is marked and read out in the title, as the UI thread's drawing
    of the shown figure has it (the worker's drawing lost it: the default probe was set later,
    in `show`, and render took the worker's drawing since the held view matched)."""
    fig = Figure(title="step", xlabel="t", ylabel="y")
    fig.series.append(Series([0.0, 1.0, 2.0, 3.0], [0.0, 0.6, 0.9, 1.0], "y"))
    built = FigurePlot.prebuild(fig, (60, 20, "textual-dark"), (None, 2))[1]
    assert built is not None and "t = 2" in built.text.plain and "y = 0.9" in built.text.plain

"""Dragging on the plots (issue 55): a compensator's zero or pole (a real root, a pair's
wn and zeta) on the pole map and the root locus, a corner along the Bode magnitude, the
magnitude curve up and down for the gain, a locus branch for the gain; one drag one undo
step, a constraint or a parameter's own bound said on release.  The
mouse events are posted at cells computed from each plot's data-to-cell mapping (its
`Frame`), and every design is checked against python-control's margins."""

from __future__ import annotations

import math

import control as ct
import pytest
from textual import events

from tests.tui.test_app import settle, synchronous
from tests.tui.test_shape_table import lead_app, start_values
from tui.app import LoopcraftApp
from tui.screens.dialogs import StartDialog
from tui.state import edits


def _loop(values) -> ct.TransferFunction:
    """K (1 + T1 s) / (1 + T2 s) / (s^2 (s + 10)): the lead session's loop."""
    return ct.tf([values["K"] * values["T1"], values["K"]], [values["T2"], 1]) * ct.tf([1], [1, 10, 0, 0])


def _post(plot, kind, cell: tuple[int, int]) -> None:
    """A mouse event at a cell of the plot's content, as the terminal's driver sends it."""
    content = plot.content_region
    sx, sy = content.x + cell[0], content.y + cell[1]
    plot.app.post_message(kind(None, sx, sy, 0, 0, 1, False, False, False, screen_x=sx, screen_y=sy))


def _cell(frame, x: float, y: float) -> tuple[int, int]:
    col, row = frame.cells(x, y)
    return round(col), round(row)


async def _drag(app, pilot, plot, start: tuple[int, int], path: list[tuple[int, int]]) -> None:
    """Press at ``start``, move along ``path``, release at its end; then wait until the
    design's plots are drawn."""
    _post(plot, events.MouseDown, start)
    for cell in path:
        _post(plot, events.MouseMove, cell)
        await pilot.pause()
    _post(plot, events.MouseUp, path[-1])
    await settle(app, pilot)


async def _shown(app, pilot, tab: str, plot_id: str):
    app.screen.set_focus(None)  # a focused plot (a press focuses it) would keep its tab shown
    app.screen.query_one("#plots").active = tab
    await settle(app, pilot)
    plot = app.screen.query_one(f"#{plot_id}")
    await pilot.wait_for_scheduled_animations()
    await settle(app, pilot)
    return plot


def _margins(values) -> tuple[float, float, float]:
    """python-control's gain margin (dB), phase margin (deg) and crossover (rad/s)."""
    gm, pm, _, _, wc, _ = ct.stability_margins(_loop(values))
    return 20 * math.log10(gm), pm, wc


def _tableau(app) -> dict[str, float]:
    """The tableau's values by kind (the design on screen)."""
    rows, _ = app.bench.view().tableau()
    return {row.kind: row.value for row in rows}


def _agrees(app) -> None:
    """The tableau's margins are python-control's of the design the drag made."""
    gm_db, pm, _ = _margins(start_values(app))
    shown = _tableau(app)
    assert shown["phase_margin_deg"] == pytest.approx(pm, abs=1e-6)
    assert shown["gain_margin_db"] == pytest.approx(gm_db, abs=1e-6)


@pytest.mark.long
@synchronous
async def test_drags_on_the_pole_map_the_bode_magnitude_and_the_locus(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    said: list[str] = []
    notify = app.notify
    monkeypatch.setattr(app, "notify", lambda message, **kw: (said.append(str(message)), notify(message, **kw)))
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        undo = len(app.bench.edits.undo_stack)

        # the pole map: the zero (at 1/T1) dragged along the real axis, the pointer off it
        plot = await _shown(app, pilot, "p-poles", "poles")
        frame = plot.drawing.frames[0]
        assert {h.name for h in plot.figure.handles} == {"compensator.zero1", "compensator.pole1"}  # no plant mark
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(frame, zero.x, zero.y)
        end = (start[0] - 3, start[1] + 1)
        await _drag(app, pilot, plot, start, [(start[0] - 1, start[1]), (start[0] - 2, start[1] - 1), end])
        assert 1 / start_values(app)["T1"] == pytest.approx(-frame.point(*end)[0], rel=1e-9)
        assert len(app.bench.edits.undo_stack) == undo + 1  # three positions, one undo step
        assert plot.navigation.box is None  # the view held still while dragging, given back on release
        _agrees(app)

        # past its bound (the session keeps T1 <= 20 T2: the zero >= 0.5 rad/s): it stops there, said
        frame = plot.drawing.frames[0]
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(frame, zero.x, zero.y)
        beyond = _cell(frame, -0.05, 0.0)
        await _drag(app, pilot, plot, start, [_cell(frame, -0.6, 0.0), beyond])
        assert 1 / start_values(app)["T1"] == pytest.approx(-frame.point(*_cell(frame, -0.6, 0.0))[0], rel=1e-9)
        assert any("T1 <= 20*T2" in text or "bound" in text for text in said[-1:]), said[-3:]
        assert len(app.bench.edits.undo_stack) == undo + 2

        # the Bode magnitude: the pole's corner along frequency, then the curve up for the gain
        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        frame = plot.drawing.frames[0]
        (pole,) = [h for h in plot.figure.handles if h.name == "compensator.pole1"]
        start = _cell(frame, pole.x, pole.y)
        end = (start[0] - 4, start[1])  # lower (higher, T1 <= 20 T2 soon bites: the zero is at 0.6)
        phase = app.screen.query_one("#bode-phase")
        drawn = phase.figure
        _post(plot, events.MouseDown, start)
        _post(plot, events.MouseMove, (start[0] - 2, start[1]))
        await settle(app, pilot)
        assert plot.figure.handles[1].x < pole.x and phase.figure is drawn  # the dragged plot alone follows
        _post(plot, events.MouseMove, end)
        _post(plot, events.MouseUp, end)
        await settle(app, pilot)
        assert phase.figure is not drawn  # every plot on release
        assert 1 / start_values(app)["T2"] == pytest.approx(10 ** frame.point(*end)[0], rel=1e-9)
        _agrees(app)
        frame = plot.drawing.frames[0]
        probe = plot.figure.probe
        corners = [_cell(frame, h.x, h.y)[0] for h in plot.figure.handles]
        i = max(range(len(probe.x)), key=lambda k: min(abs(_cell(frame, probe.x[k], 0)[0] - c) for c in corners))
        start = _cell(frame, probe.x[i], probe.y[i])  # the curve's point farthest from the corners
        gain = start_values(app)["K"]
        end = (start[0] + 1, start[1] - 1)  # a row up (17 dB at this size)
        await _drag(app, pilot, plot, start, [end])
        rise = frame.point(*end)[1] - frame.point(*start)[1]
        assert start_values(app)["K"] == pytest.approx(gain * 10 ** (rise / 20), rel=1e-9) and rise > 0
        _agrees(app)
        assert len(app.bench.edits.undo_stack) == undo + 4

        # the root locus: along a branch, the loop gain at the nearest point
        plot = await _fine_locus(app, pilot)
        frame, probe = plot.drawing.frames[0], plot.figure.probe
        values = start_values(app)
        (x0, x1), (_, y1) = frame.xlim, frame.ylim
        marks = [_cell(frame, h.x, h.y) for h in plot.figure.handles]

        def clear(k: int) -> bool:  # a point of the upper half in view, away from the compensator's marks
            col, row = _cell(frame, probe.x[k], probe.y[k])
            inside = 0.3 * y1 < probe.y[k] < y1 and x0 < probe.x[k] < x1
            return inside and all(max(abs(col - c), abs(row - r)) > 3 for c, r in marks)

        upper = [k for k in range(len(probe.x)) if clear(k)]
        a, b = upper[len(upper) // 3], upper[2 * len(upper) // 3]
        start, end = _cell(frame, probe.x[a], probe.y[a]), _cell(frame, probe.x[b], probe.y[b])
        _post(plot, events.MouseDown, start)
        _post(plot, events.MouseMove, end)
        await settle(app, pilot)
        assert "coarse: exact on release" in plot.figure.title  # held: the coarse locus alone
        _post(plot, events.MouseUp, end)
        await settle(app, pilot)
        assert "coarse" not in plot.figure.title  # released: refined
        x, y = frame.point(*end)
        across, up = (frame.right - frame.left) / (x1 - x0), 2 * (frame.bottom - frame.top) / (y1 - frame.ylim[0])
        nearest = min(range(len(probe.x)), key=lambda k: math.hypot((probe.x[k] - x) * across, (probe.y[k] - y) * up))
        after = start_values(app)
        assert after["K"] == pytest.approx(values["K"] * probe.chosen(nearest), rel=1e-9)
        poles = ct.poles(ct.feedback(_loop(after), 1))
        point = complex(probe.x[nearest], probe.y[nearest])
        assert min(abs(poles - point)) <= 1e-6 * abs(point)  # the point is a closed-loop pole of the design
        _agrees(app)

        # v types where the cursor goes: the Bode magnitude's point nearest 2.5 rad/s
        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        plot.focus()
        await pilot.press("v")
        await pilot.pause()
        app.screen.query_one("#value").value = "2.5"
        await pilot.press("enter")
        await settle(app, pilot)
        x = plot.figure.probe.x
        assert plot.navigation.cursor == min(range(len(x)), key=lambda k: abs(x[k] - math.log10(2.5)))
        assert app.screen.query_one("#bode-phase").navigation.cursor == plot.navigation.cursor  # linked

        # undo takes the drags back one at a time
        for _ in range(5):
            await pilot.press("ctrl+z")
            await settle(app, pilot)
        assert start_values(app) == {"K": 1.0, "T1": 1.0, "T2": 0.1}

        # a pair: a notch added (its zeros zeta 0.05, its poles zeta 0.5), the poles' upper
        # mark dragged on the pole map: the pair's upper root goes to the pointer (wn, zeta)
        app.screen.shaping.change(lambda: edits.add_part(app.bench, "compensator", "notch"), "a notch")
        plot = await _shown(app, pilot, "p-poles", "poles")
        frame = plot.drawing.frames[0]
        (upper,) = [h for h in plot.figure.handles if h.name == "compensator.polepair1" and h.y > 0]
        start = _cell(frame, upper.x, upper.y)
        end = (start[0] - 1, start[1] - 1)  # up and to the left (a column is 0.3 rad/s here)
        await _drag(app, pilot, plot, start, [(start[0], start[1] - 1), end])
        target = complex(*frame.point(*end))
        values = app.bench.session.problem.condition_values(0)
        wn, zeta = values["notch1_wp"], values["notch1_zp"]
        assert complex(-zeta * wn, wn * math.sqrt(1 - zeta**2)) == pytest.approx(target, rel=1e-9)
        poles = ct.poles(ct.tf([1], [1 / wn**2, 2 * zeta / wn, 1]))  # python-control's roots of the pair's factor
        assert min(abs(poles - target)) <= 1e-9 * abs(target)

        # after an iteration, the drag asks where to start from once, on release, and moves then
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 1 and app.bench.start is None
        frame = plot.drawing.frames[0]
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(frame, zero.x, zero.y)
        end = (start[0] - 2, start[1])
        design = app.bench.view().parameters(None, 0)
        _post(plot, events.MouseDown, start)
        _post(plot, events.MouseMove, (start[0] - 1, start[1]))
        await settle(app, pilot)
        assert not isinstance(app.screen, StartDialog) and app.bench.iteration == 1  # nothing moved yet
        _post(plot, events.MouseUp, end)
        await settle(app, pilot)
        assert isinstance(app.screen, StartDialog)
        await pilot.press("y")  # the design on screen is the start
        await settle(app, pilot)
        values = start_values(app)
        assert app.bench.iteration == 0 and 1 / values["T1"] == pytest.approx(-frame.point(*end)[0], rel=1e-9)
        assert values["K"] == pytest.approx(design["K"], rel=1e-12)  # the iteration's design, the zero moved


def test_the_cursor_steps_a_column_of_the_view_and_goes_to_a_typed_value():
    """left/right move the cursor a column of the view (ten with shift), at least a point:
    zoomed out a key jumps many points, zoomed in it moves one; v puts it at a value."""
    from tui.figures.data import Figure, Series
    from tui.figures.navigation import Navigation, xy_probe

    x = [k / 100 for k in range(401)]  # log10 of 1 to 10^4 rad/s, 100 points a decade
    curve = Series(x, [-20 * v for v in x])
    figure = Figure(series=[curve], probe=xy_probe(curve), log_x=True)
    nav = Navigation()
    nav.move(figure, 1, column=0.0625)  # the cursor appears mid-curve
    assert nav.cursor == 200
    nav.move(figure, 1, column=0.0625)  # a column: 6.25 points, so the seventh
    assert nav.cursor == 207
    nav.move(figure, -10, column=0.0625)  # shift: ten columns back
    assert nav.cursor == 207 - 63 == 144
    nav.move(figure, 1, column=0.001)  # zoomed in: a column is less than a point
    assert nav.cursor == 145
    nav.move(figure, -1)  # no view known: a point
    assert nav.cursor == 144
    assert nav.go_to(figure, 50.0) and nav.cursor == 170  # log10(50) = 1.699
    assert not nav.go_to(figure, -1.0) and nav.cursor == 170  # no frequency below zero


@synchronous
async def test_drags_on_a_sampled_loop_move_its_roots_in_z(tmp_path, monkeypatch):
    """A lead in z (Tustin's map, T = 0.1 s): its zero dragged on the pole map (drawn in z)
    goes to the pointer's real part in z, and its corner dragged along the Bode magnitude
    puts its s-plane equivalent's frequency at the pointer's; python-control's Tustin
    discretization of the lead gives the same zero."""
    from tui.cli import main

    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    path, T = tmp_path / "lead_z.json", 0.1
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead", "--sample-time", "0.1"]) == 0

    def zero_in_z() -> float:
        values = start_values(app)
        (zero,) = ct.zeros(ct.sample_system(ct.tf([values["T1"], 1], [values["T2"], 1]), T, method="tustin"))
        return float(zero.real)

    app = LoopcraftApp(path)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = await _shown(app, pilot, "p-poles", "poles")
        frame = plot.drawing.frames[0]
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        assert zero.x == pytest.approx(zero_in_z(), rel=1e-9)  # drawn in z
        start = _cell(frame, zero.x, zero.y)
        end = (start[0] - 2, start[1] - 1)  # a smaller z: a faster zero
        await _drag(app, pilot, plot, start, [(start[0] - 1, start[1]), end])
        assert zero_in_z() == pytest.approx(frame.point(*end)[0], rel=1e-9)

        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        frame = plot.drawing.frames[0]
        (corner,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(frame, corner.x, corner.y)
        end = (start[0] - 3, start[1])
        await _drag(app, pilot, plot, start, [end])
        assert -math.log(zero_in_z()) / T == pytest.approx(10 ** frame.point(*end)[0], rel=1e-9)


@synchronous
async def test_a_drag_is_coarse_while_held_exact_on_release_and_keeps_its_item_past_another(tmp_path, monkeypatch):
    """A second lead added (its zero at a third of the crossover, below the first lead's
    at 1 rad/s: zero1) and its zero dragged along the Bode magnitude past the lead's zero.  While the button is
    held the magnitude alone is drawn anew, coarse (its title says so, `COARSE_POINTS`
    frequencies, no margin marks), from the worker's drawing in the view held still; the
    drag keeps moving the zero it pressed (now zero2) while the lead's stays at 1 rad/s, and
    selects no text;
    on release every plot is exact, drawn by the worker alone (the coarse figure is not drawn
    again in the view given back first), and the margins are python-control's of the design."""
    import threading

    from tui.drawing.text_canvas import draw
    from tui.figures.catalog import COARSE_POINTS

    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        app.screen.shaping.change(lambda: edits.add_part(app.bench, "compensator", "lead"), "a lead")
        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        phase = app.screen.query_one("#bode-phase")
        frame, drawn = plot.drawing.frames[0], phase.figure
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        added, pole = sorted(name for name in start_values(app) if name not in ("K", "T1", "T2"))[::-1]  # Tz, Tp
        assert 10**zero.x == pytest.approx(1 / start_values(app)[added], rel=1e-9) and 10**zero.x < 1
        start = _cell(frame, zero.x, zero.y)
        beyond = _cell(frame, math.log10(3.0), zero.y)[0]
        path = [(col, start[1]) for col in range(start[0] + 2, beyond + 1, 2)]
        _post(plot, events.MouseDown, start)
        for cell in path:
            _post(plot, events.MouseMove, cell)
            await settle(app, pilot)
        assert "coarse" in plot.figure.title and phase.figure is drawn
        assert len(plot.figure.series[0].x) <= COARSE_POINTS and not any("PM" in s.label for s in plot.figure.series)
        assert plot.drawing is plot._prebuilt[1]  # the worker's drawing, in the view held still
        assert app.screen._select_state is None  # no text selected (the whole screen repainted a move)
        drawn_here = []  # drawings made on the UI thread (a plot's render without the worker's)

        def counted(*args):
            if threading.current_thread() is threading.main_thread():
                drawn_here.append(args[0].title)
            return draw(*args)

        monkeypatch.setattr("tui.widgets.plots.draw", counted)
        _post(plot, events.MouseUp, path[-1])
        await settle(app, pilot)
        assert not drawn_here and plot.drawing is plot._prebuilt[1]  # the release's figures: the worker's
        values = start_values(app)
        assert 1 / values[added] == pytest.approx(10 ** frame.point(*path[-1])[0], rel=1e-9) and values["T1"] == 1.0
        names = {h.name: 10**h.x for h in plot.figure.handles}
        assert names["compensator.zero2"] == pytest.approx(1 / values[added], rel=1e-9)
        assert names["compensator.zero1"] == pytest.approx(1.0, rel=1e-9)
        assert "coarse" not in plot.figure.title and phase.figure is not drawn
        assert any("PM" in s.label for s in plot.figure.series) and len(plot.figure.series[0].x) > COARSE_POINTS
        loop = _loop(values) * ct.tf([values[added], 1], [values[pole], 1])
        gm, pm, _, _, _, _ = ct.stability_margins(loop)
        shown = _tableau(app)
        assert shown["phase_margin_deg"] == pytest.approx(pm, abs=1e-6)
        assert shown["gain_margin_db"] == pytest.approx(20 * math.log10(gm), abs=1e-6)


@synchronous
async def test_a_drag_s_moves_render_the_dragged_plot_and_the_tableau_alone(tmp_path, monkeypatch):
    """Each move of a drag after the first renders the dragged plot and the tableau again
    and nothing else (a count of the widgets' renders, not a time): the status line says a
    drag goes (one text for the drag; the edit on release), and a text set to what it shows
    repaints nothing (the step's lines).  Before, the status line and the step's lines
    were rendered again at every move."""
    from textual.widget import Widget

    from tui.screens.main import DRAGGING
    from tui.screens.pole_lines import COMPUTING

    app = lead_app(tmp_path, monkeypatch)
    rendered: list[str | None] = []
    render = Widget._render_content
    monkeypatch.setattr(Widget, "_render_content", lambda self: rendered.append(self.id) or render(self))
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        tableau = app.screen.query_one("#tableau")
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(plot.drawing.frames[0], zero.x, zero.y)
        _post(plot, events.MouseDown, start)
        for k in range(4):
            values, shown = start_values(app), plot.figure
            rendered.clear()
            _post(plot, events.MouseMove, (start[0] + 1 + k % 2, start[1]))
            for _ in range(200):  # the move's frame drawn and painted, the pole lines under the tableau come
                await settle(app, pilot)
                if plot.figure is not shown and "bode-mag" in rendered and COMPUTING not in tableau.text.plain:
                    break
            await settle(app, pilot)
            assert start_values(app) != values and "tableau" in rendered  # the design followed
            if k:
                assert set(rendered) == {"bode-mag", "tableau"}, rendered
        _post(plot, events.MouseUp, (start[0] + 1, start[1]))
        await settle(app, pilot)
        status = app.screen.query_one("#status").text.plain
        assert DRAGGING not in status and app.bench.edits.last in status  # released: the edit said


@synchronous
async def test_a_drag_s_frames_draw_the_moving_curve_over_one_static_layer(tmp_path, monkeypatch):
    """The lead's zero dragged along the Bode magnitude: the first frame builds the static
    layer of the view held (frame, axes, ticks, labels) and every later frame builds nothing
    with plotext (a count of plotext's builds, not a time), its text still plotext's whole
    drawing of the frame's figure in that view; and the plot's strips are made without Rich's
    render (`RichVisual.render_strips`: never called for it).  Before, plotext drew the whole
    plot again each frame and Rich rendered its text."""
    from plotext._monitor import monitor_class
    from textual.visual import RichVisual

    from tui.drawing import text_canvas
    from tui.drawing.text_layers import Layers

    monkeypatch.setattr(text_canvas, "LAYERS", Layers())
    builds: list[int] = []
    build = monitor_class.build_plot
    monkeypatch.setattr(monitor_class, "build_plot", lambda self: builds.append(1) or build(self))
    by_rich: list[str | None] = []
    rich_strips = RichVisual.render_strips
    monkeypatch.setattr(
        RichVisual, "render_strips", lambda self, *args: by_rich.append(self._widget.id) or rich_strips(self, *args)
    )
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(plot.drawing.frames[0], zero.x, zero.y)
        _post(plot, events.MouseDown, start)
        await settle(app, pilot)
        per_frame = []
        by_rich.clear()
        for k in range(5):
            shown = plot.figure
            builds.clear()
            _post(plot, events.MouseMove, (start[0] + 1 + k, start[1]))
            for _ in range(200):
                await settle(app, pilot)
                if plot.figure is not shown and plot.drawing is plot._prebuilt[1]:
                    break
            per_frame.append(len(builds))
            with monkeypatch.context() as whole:
                whole.setattr(text_canvas, "layered_text", lambda *args: None)
                expected = text_canvas.draw(plot.shown, *plot.canvas())
            assert "coarse" in plot.figure.title and expected is not None
            assert (plot.drawing.text.plain, plot.drawing.text.spans) == (expected.text.plain, expected.text.spans)
        _post(plot, events.MouseUp, (start[0] + 5, start[1]))
        await settle(app, pilot)
    assert per_frame == [1, 0, 0, 0, 0], per_frame
    assert "bode-mag" not in by_rich


async def _frames(app, pilot, monkeypatch, frames: int, tab: str, plot_id: str) -> tuple[list[bool], list[bool]]:
    """The lead's zero dragged one column at a time (right along the Bode magnitude, left
    along the locus's real axis): per move, whether its frame was asked of a worker, and
    whether the dragged plot already showed the move's design when the move had been
    handled (before any worker ran or the screen painted again)."""
    from tui.screens.latest_work import LatestWork
    from tui.screens.shaping import Shaping

    plot = await _shown(app, pilot, tab, plot_id)
    asked: list[str] = []
    request = LatestWork.request
    monkeypatch.setattr(LatestWork, "request", lambda self, *args: asked.append(self.group) or request(self, *args))
    at_once: list[bool] = []
    handled = Shaping.drag

    def noted(self, message) -> None:
        shown = plot.figure
        handled(self, message)
        at_once.append(plot.figure is not shown)

    monkeypatch.setattr(Shaping, "drag", noted)
    (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
    start = _cell(plot.drawing.frames[0], zero.x, zero.y)
    step = 1 if plot_id == "bode-mag" else -1
    _post(plot, events.MouseDown, start)
    await settle(app, pilot)
    by_worker = []
    for k in range(frames):
        asked.clear()
        values = start_values(app)
        _post(plot, events.MouseMove, (start[0] + step * (1 + k), start[1]))
        await settle(app, pilot)
        assert start_values(app) != values
        by_worker.append(bool(asked))
    _post(plot, events.MouseUp, (start[0] + step * frames, start[1]))
    await settle(app, pilot)
    _agrees(app)
    return by_worker, at_once[:frames]


@pytest.mark.parametrize(("tab", "plot_id"), [("p-bode", "bode-mag"), ("p-locus", "locus")])
@synchronous
async def test_a_drag_s_quick_frames_are_drawn_at_once_with_the_tableau(tmp_path, monkeypatch, tab, plot_id):
    """A plot's first drag frame is drawn by a worker (its cost unknown); once a frame took
    less than `INLINE_FRAME_S` to draw (a few ms on the lead's Bode plot, 15-30 on its
    root locus), the next ones are drawn
    while the move is handled, so that the tableau and the plot come in one paint (a
    worker's frame waited for a second paint), on the Bode magnitude (the figures' worker)
    as on the root locus (its own); with a bound that nothing meets, every frame goes to
    the worker and the plot follows once it is done.  Before, every frame was the worker's.
    (The bound is set here, one that every frame meets and one that none does, so that the
    test asks what the policy does, not how fast this machine draws.)"""
    monkeypatch.setattr("tui.screens.latest_work.INLINE_FRAME_S", 10.0)
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        for _ in range(2):  # a second drag's first frame is of unknown cost again: the worker's
            by_worker, at_once = await _frames(app, pilot, monkeypatch, 4, tab, plot_id)
            assert by_worker[0] and not any(by_worker[1:]), by_worker
            assert at_once[1:] == [True, True, True], at_once
    monkeypatch.setattr("tui.screens.latest_work.INLINE_FRAME_S", 0.0)
    (tmp_path / "unmet").mkdir()
    app = lead_app(tmp_path / "unmet", monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        by_worker, at_once = await _frames(app, pilot, monkeypatch, 3, tab, plot_id)
    assert by_worker == [True, True, True] and not any(at_once), (by_worker, at_once)


@synchronous
async def test_positions_a_drag_has_not_handled_yet_give_way_to_the_latest(tmp_path, monkeypatch):
    """Three positions of one drag posted before the screen handles any: it handles the
    last alone (Textual drops a message whose `can_replace` says the next supersedes it),
    so a pointer faster than the frames is followed to where it is; a release and another
    drag's position are never dropped."""
    from tui.screens.shaping import Shaping
    from tui.widgets.plots import FigurePlot

    app = lead_app(tmp_path, monkeypatch)
    seen: list[tuple[float, bool]] = []
    drag = Shaping.drag
    monkeypatch.setattr(
        Shaping, "drag", lambda self, message: seen.append((message.x, message.done)) or drag(self, message)
    )
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]

        def dragged(x: float, done: bool = False, drag: int = 1) -> FigurePlot.Dragged:
            return FigurePlot.Dragged(plot, zero, x, zero.y, None, done, drag)

        for x in (zero.x + 0.01, zero.x + 0.02, zero.x + 0.03):
            plot.post_message(dragged(x))
        await settle(app, pilot)
        assert seen == [(zero.x + 0.03, False)], seen
        seen.clear()
        for message in (
            dragged(zero.x + 0.04, done=True),
            dragged(zero.x + 0.05, drag=2),
            dragged(zero.x + 0.06, drag=2),
        ):
            plot.post_message(message)
        await settle(app, pilot)
        assert seen == [(zero.x + 0.04, True), (zero.x + 0.06, False)], seen
        plot.post_message(dragged(zero.x + 0.06, done=True, drag=2))
        await settle(app, pilot)


@synchronous
async def test_a_frame_that_cannot_be_drawn_at_once_goes_to_the_worker_which_says_why(tmp_path, monkeypatch):
    """A drag frame drawn on the UI thread that raises (a figure that cannot be made) does
    not end the app: the frame is asked of the worker, which says what failed, and the
    plot's later frames stay with the worker."""
    from tui.screens import main

    monkeypatch.setattr("tui.screens.latest_work.INLINE_FRAME_S", 10.0)  # every frame quick: this machine's speed aside
    app = lead_app(tmp_path, monkeypatch)
    notes: list[str] = []
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        monkeypatch.setattr(app.screen, "notify", lambda message, **kw: notes.append(message))
        plot = await _shown(app, pilot, "p-bode", "bode-mag")
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(plot.drawing.frames[0], zero.x, zero.y)
        _post(plot, events.MouseDown, start)
        _post(plot, events.MouseMove, (start[0] + 1, start[1]))
        await settle(app, pilot)
        assert app.screen.frame_times._seconds["bode-mag"] < math.inf  # the next frame is drawn at once

        def broken(*args, **kwargs):
            raise ValueError("no figure here")

        monkeypatch.setattr(main, "drawings", broken)
        _post(plot, events.MouseMove, (start[0] + 2, start[1]))
        await settle(app, pilot)
        assert app.is_running and notes == ["ValueError: no figure here"], notes
        assert app.screen.frame_times._seconds["bode-mag"] == math.inf


async def _fine_locus(app, pilot):
    """The root locus shown, its fine pass drawn and painted (a worker draws the coarse one first)."""
    plot = await _shown(app, pilot, "p-locus", "locus")
    for _ in range(20):
        drawn = plot.drawing is not None and plot.drawing.frames[0].xlim == plot.figure.xlim
        if plot.figure.series and "coarse" not in plot.figure.title and drawn:
            break
        await settle(app, pilot)
    assert "coarse" not in plot.figure.title and plot.drawing.frames[0].xlim == plot.figure.xlim
    return plot


def _notched(values) -> ct.TransferFunction:
    """The lead's loop with the notch part's factor (1 + 2 zz s/wz + (s/wz)^2) / (1 + 2 zp s/wp + (s/wp)^2)."""
    wz, zz, wp, zp = (values[f"notch1_{p}"] for p in ("wz", "zz", "wp", "zp"))
    return _loop(values) * ct.tf([1 / wz**2, 2 * zz / wz, 1], [1 / wp**2, 2 * zp / wp, 1])


@synchronous
async def test_the_compensator_s_marks_dragged_on_the_root_locus(tmp_path, monkeypatch):
    """On the root locus, as on the pole map: the lead's zero mark dragged along the real axis
    goes to the pointer's abscissa, then a notch's upper pole mark to the pointer (its pair's wn
    and zeta); the tableau's margins are python-control's of each design."""
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = await _fine_locus(app, pilot)
        frame = plot.drawing.frames[0]
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        start = _cell(frame, zero.x, zero.y)
        end = (start[0] - 2, start[1] - 1)  # a faster zero (the pointer off the axis: its abscissa counts)
        await _drag(app, pilot, plot, start, [(start[0] - 1, start[1]), end])
        assert 1 / start_values(app)["T1"] == pytest.approx(-frame.point(*end)[0], rel=1e-9)
        assert -frame.point(*end)[0] > 1.0
        _agrees(app)

        app.screen.shaping.change(lambda: edits.add_part(app.bench, "compensator", "notch"), "a notch")
        plot = await _fine_locus(app, pilot)
        frame = plot.drawing.frames[0]
        (upper,) = [h for h in plot.figure.handles if h.name == "compensator.polepair1" and h.y > 0]
        start = _cell(frame, upper.x, upper.y)
        end = (start[0] - 1, start[1] - 1)
        await _drag(app, pilot, plot, start, [(start[0], start[1] - 1), end])
        target = complex(*frame.point(*end))
        values = start_values(app)
        wn, zeta = values["notch1_wp"], values["notch1_zp"]
        assert complex(-zeta * wn, wn * math.sqrt(1 - zeta**2)) == pytest.approx(target, rel=1e-9)
        gm, pm, _, _, _, _ = ct.stability_margins(_notched(values))
        shown = _tableau(app)
        assert shown["phase_margin_deg"] == pytest.approx(pm, abs=1e-6)
        assert shown["gain_margin_db"] == pytest.approx(20 * math.log10(gm), abs=1e-6)


@synchronous
async def test_a_drag_past_a_parameter_s_own_bound_stops_at_it_and_says_so(tmp_path, monkeypatch):
    """T1 given a min of 0.5 (its own bound; the constraints T1 <= 20 T2 and T2 <= 20 T1 hold
    throughout): the lead's zero (at 1/T1) dragged on the pole map from 1 to 1.5 rad/s follows,
    past 2 rad/s it stays at the last position accepted, and the release says which bound."""
    import json

    from tui.cli import main

    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    session = json.loads(path.read_text())
    (t1,) = [p for p in session["problem"]["parameters"] if p["name"] == "T1"]
    t1["min"] = 0.5
    path.write_text(json.dumps(session))
    app = LoopcraftApp(path)
    said: list[str] = []
    notify = app.notify
    monkeypatch.setattr(app, "notify", lambda message, **kw: (said.append(str(message)), notify(message, **kw)))
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plot = await _shown(app, pilot, "p-poles", "poles")
        frame = plot.drawing.frames[0]
        (zero,) = [h for h in plot.figure.handles if h.name == "compensator.zero1"]
        inside, beyond = _cell(frame, -1.5, 0.0), _cell(frame, -3.0, 0.0)
        await _drag(app, pilot, plot, _cell(frame, zero.x, zero.y), [inside, beyond])
        values = start_values(app)
        assert 1 / values["T1"] == pytest.approx(-frame.point(*inside)[0], rel=1e-9) and values["T1"] > 0.5
        frequency = -frame.point(*beyond)[0]
        assert said[-1] == (
            "not applied (nothing changed): compensator.zero1: no value of T1 within its bounds brings the zero's "
            f"frequency to {frequency:.6g} (T1: min 0.5, max 10000)"
        )

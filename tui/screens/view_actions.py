"""The workbench's actions on what it shows: the step plot's signals, copying
to the clipboard, and the root locus computed off the UI thread (its worker
posts it back: `ViewActions.LocusDrawn`).  A part composed into the main screen
(``screen.view_actions``)."""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

from textual.message import Message
from textual.widgets import DataTable, TabbedContent

from engine.closed_loop.step_response import horizon
from tui.figures import overlays
from tui.figures.catalog import Same, compensator_roots
from tui.figures.closed_loop import COARSE_LOCUS_POINTS, locus_figure
from tui.figures.data import Figure
from tui.figures.requirements import requirements
from tui.screens.dialogs import EditDialog
from tui.screens.latest_work import LatestWork
from tui.state import edits
from tui.state.clipboard import design_text, row_text
from tui.state.step_view import format_step_setup, parse_step_setup
from tui.state.views import View
from tui.widgets.plots import FigurePlot
from tui.widgets.shape_table import ShapeTable
from tui.widgets.textview import TextView

if TYPE_CHECKING:
    from tui.screens.main import MainScreen

LOCUS = frozenset({"locus"})  # the plot a locus drag's frames are timed for (`FrameTimes`)


class ViewActions:
    """The step plot's signals, copies to the clipboard, the root locus."""

    class LocusDrawn(Message):
        """A thread worker's root locus for the design of ``key``."""

        def __init__(self, key: tuple, figure: Figure, frame_s: float | None = None) -> None:
            super().__init__()
            self.key, self.figure, self.frame_s = key, figure, frame_s  # frame_s: a drag frame's drawing time

    def __init__(self, screen: MainScreen) -> None:
        self.screen = screen
        self.locus_parameter = "gain"  # what the root locus varies
        self._locus_key: tuple | None = None  # what the root locus shown was computed for
        self._locus_work = LatestWork(screen, "locus")  # one locus at a time, the latest design's next

    def forget_locus(self) -> None:
        """The design changed: the locus shown is computed again when its tab is shown."""
        self._locus_key = None

    def step_setup(self) -> None:
        """Ask which input is stepped, which output is plotted and for how long."""
        view = self.screen.bench.view()
        ss = view.step_loop(view.first_plotted)
        signals = view.step_signals(view.first_plotted)
        if signals is None:
            self.screen.app.notify(
                "no step response here (it needs a rational plant, or a continuous one with delays or tables)",
                severity="warning",
            )
            return
        inputs, outputs = signals

        def check(text: str) -> str | None:
            try:
                parse_step_setup(text, inputs, outputs)
            except ValueError as exc:
                return str(exc)
            return None

        def typed(text: str | None) -> None:
            if text is not None:
                self.screen.bench.step_setup = parse_step_setup(text, inputs, outputs)
                self.screen.refresh_plots()

        default = (
            f"horizon {horizon(ss):.3g} s from the slowest pole"
            if ss is not None
            else "the horizon from the rightmost characteristic root, simulated with the delays"
        )
        title = (
            f"step plot: INPUT OUTPUT [HORIZON s] (empty: defaults, {default})\n"
            f"inputs: {', '.join(inputs)}\nsignals: {', '.join(outputs)}"
        )
        self.screen.app.push_screen(
            EditDialog(title, format_step_setup(self.screen.bench.step_setup, ss), check), typed
        )

    def copy(self) -> None:
        """The focused table's selected row, else the tableau, to the clipboard."""
        focused = self.screen.focused
        if isinstance(focused, (DataTable, ShapeTable)) and focused.row_count:
            text, what = row_text(focused.get_row_at(focused.cursor_row)), "the row"
        else:
            text, what = self.screen.query_one("#tableau", TextView).text.plain, "the tableau"
        self.screen.app.copy_to_clipboard(text)
        self.screen.app.notify(f"copied {what} ({len(text)} characters)", timeout=3)

    def copy_design(self) -> None:
        view = self.screen.bench.view()
        condition = view.first_plotted
        text = (
            design_text(self.screen.bench.session.model.problem, view.parameters(None, condition), condition)
            if self.screen.bench.session.model.problem.conditions
            else ""
        )
        if not text:
            self.screen.app.notify("no block of this session reads a parameter", severity="warning")
            return
        self.screen.app.copy_to_clipboard(text)
        self.screen.app.notify(f"copied the design:\n{text}", timeout=6)

    def refresh_locus(self, view: View | None = None) -> None:
        """The root locus, computed in a thread worker only while its tab is shown
        (a locus of a dozen bending modes takes seconds): coarse first, then refined, one
        design at a time and only the latest one waiting (`LatestWork`: a held shaping key
        never queues stale loci); kept until the design changes.  While a drag on the
        locus goes, the coarse one alone, the last one shown until it comes (or drawn at once
        when the last frame was quick: `FrameTimes`); the release refines it."""
        screen = self.screen
        plots = screen.query_one_optional("#plots", TabbedContent)
        if plots is None or plots.active != "p-locus" or self.screen.query_one_optional("#locus") is None:
            return
        view = self.screen.bench.view() if view is None else view
        dragged = screen.dragged_plot == "locus"
        key = (Same(view.problem), view.iteration, view.plotted_condition, self.locus_parameter, dragged)
        if key == self._locus_key:
            return
        self._locus_key = key
        if not dragged:
            self.screen.query_one("#locus", FigurePlot).show(Figure(empty_message="computing the root locus ..."))

        parameter = self.locus_parameter
        passes = (COARSE_LOCUS_POINTS,) if dragged else (COARSE_LOCUS_POINTS, None)  # coarse, then as fine as it goes

        def drawn(points: int | None, roots: list) -> ViewActions.LocusDrawn:
            began = time.thread_time()  # the drawing's own time, not the paints it waited on
            figure = locus_figure(view, parameter, points=points, refining=not dragged)
            overlays.poles(figure, requirements(view))
            overlays.compensator_roots(figure, roots)
            return self.LocusDrawn(key, figure, time.thread_time() - began if dragged else None)

        def compute() -> None:
            roots = compensator_roots(view)  # the same for the coarse locus and the fine one
            for points in passes:
                if key != self._locus_key:
                    return  # a newer design is asked for: this one is passed over
                screen.post_message(drawn(points, roots))

        if dragged and screen.frame_times.at_once(LOCUS, self._locus_work):  # painted with the tableau
            try:
                self.locus_drawn(drawn(COARSE_LOCUS_POINTS, compensator_roots(view)))
                return
            except Exception:  # noqa: BLE001 - the worker draws it again and says what failed (`LatestWork`)
                screen.frame_times.took(LOCUS, math.inf)
        self._locus_work.request(compute, key)

    def choose_locus_parameter(self) -> None:
        """Choose what the root locus varies, the loop gain or one parameter, and show the
        locus: History's plot when that tab is shown, else the Run tab's."""
        from tui.screens.dialogs import ChooseDialog

        names = [p.name for p in self.screen.bench.session.problem.parameters]
        choices = [("gain", "the loop gain k (1 + k L = 0)")] + [
            (n, "this parameter, a decade either side") for n in names
        ]

        def chosen(name: str | None) -> None:
            if not name:
                return
            self.locus_parameter = name
            if self.screen.query_one("#tabs").active == "history":
                self.screen.query_one("#history-pane").show_view("locus")
                return
            self.screen.query_one("#plots").active = "p-locus"
            self.refresh_locus()

        self.screen.app.push_screen(ChooseDialog("root locus in", choices), chosen)

    def adopt_locus_value(self, value: float) -> None:
        """enter on the Run tab's root locus: the design takes the value at the cursor (the
        loop gain k there, through the gain parameter; or the locus's parameter's value)."""
        bench, parameter = self.screen.bench, self.locus_parameter
        view = bench.view()
        k = view.first_plotted
        if parameter == "gain":
            what = f"multiply the loop by k = {value:.5g} (the root locus's cursor)"
            self.screen.app.edit_flow.change(
                lambda: edits.scale_gain(bench, k, value),
                what,
                done=lambda name: self.screen.app.notify(f"{name} scaled by {value:.5g}: the loop gain at the cursor"),
            )
            return
        self.screen.app.edit_flow.change(
            lambda: edits.set_parameters(bench, {parameter: value}, k),
            f"{parameter} = {value:.5g} (the root locus's cursor)",
        )

    def go_to(self, plot: FigurePlot) -> None:
        """v on a plot: ask for a value of x (a frequency on a frequency axis), then put the
        cursor on the curve's point nearest it."""
        from tui.screens.shaping import finite, positive

        frequency = plot.figure.log_x
        title = f"the cursor to {plot.figure.xlabel or 'x'}" + (" (a frequency)" if frequency else "")
        self.screen.app.edit_flow.ask(title, positive if frequency else finite, lambda text: plot.go_to(float(text)))

    def locus_drawn(self, message: ViewActions.LocusDrawn) -> None:
        if message.frame_s is not None:
            self.screen.frame_times.took(LOCUS, message.frame_s)
        if message.key == self._locus_key:
            self.screen.query_one("#locus", FigurePlot).show(message.figure)

"""The workbench's actions on what it shows: the step plot's signals, copying
to the clipboard, and the root locus computed off the UI thread."""

from __future__ import annotations

from textual.widgets import DataTable, TabbedContent

from tui.figures.closed_loop import locus_figure
from tui.figures.data import Figure
from tui.screens.dialogs import EditDialog
from tui.state.clipboard import design_text, row_text
from tui.state.step_view import format_step_setup, horizon, parse_step_setup
from tui.state.views import View
from tui.widgets.plots import FigurePlot
from tui.widgets.textview import TextView


class ViewActions:
    """Mixed into `MainScreen`: needs ``bench``, ``app`` and the screen's widgets."""

    locus_parameter = "gain"  # what the root locus varies

    def action_step_setup(self) -> None:
        """Ask which input is stepped, which output is plotted and for how long."""
        view = self.bench.view()
        ss = view.step_loop(view.plotted()[0] if view.plotted() else 0)
        if ss is None:
            self.app.notify("no step response here (it needs a rational plant)", severity="warning")
            return

        def check(text: str) -> str | None:
            try:
                parse_step_setup(text, ss.inputs, ss.outputs)
            except ValueError as exc:
                return str(exc)
            return None

        def typed(text: str | None) -> None:
            if text is not None:
                self.bench.step_setup = parse_step_setup(text, ss.inputs, ss.outputs)
                self.refresh_plots()

        title = (
            f"step plot: INPUT OUTPUT [HORIZON s] (empty: defaults, horizon {horizon(ss):.3g} s from the "
            f"slowest pole)\ninputs: {', '.join(ss.inputs)}\nsignals: {', '.join(ss.outputs)}"
        )
        self.app.push_screen(EditDialog(title, format_step_setup(self.bench.step_setup, ss), check), typed)

    def action_copy(self) -> None:
        """The focused table's selected row, else the tableau, to the clipboard."""
        focused = self.focused
        if isinstance(focused, DataTable) and focused.row_count:
            text, what = row_text(focused.get_row_at(focused.cursor_row)), "the row"
        else:
            text, what = self.query_one("#tableau", TextView).text.plain, "the tableau"
        self.app.copy_to_clipboard(text)
        self.app.notify(f"copied {what} ({len(text)} characters)", timeout=3)

    def action_copy_design(self) -> None:
        view = self.bench.view()
        condition = view.plotted()[0] if view.plotted() else 0
        text = (
            design_text(self.bench.session.model.problem, view.parameters(None, condition), condition)
            if self.bench.session.model.problem.conditions
            else ""
        )
        if not text:
            self.app.notify("no block of this session reads a parameter", severity="warning")
            return
        self.app.copy_to_clipboard(text)
        self.app.notify(f"copied the design:\n{text}", timeout=6)

    def refresh_locus(self, view: View | None = None) -> None:
        """The root locus, computed in a thread worker only while its tab is shown
        (a locus of a dozen bending modes takes seconds); kept until the design changes."""
        plots = self.query_one_optional("#plots", TabbedContent)
        if plots is None or plots.active != "p-locus" or self.query_one_optional("#locus") is None:
            return
        view = self.bench.view() if view is None else view
        key = (id(view.problem), view.iteration, view.plotted_condition, self.locus_parameter)
        if key == self._locus_key:
            return
        self._locus_key = key
        self.query_one("#locus", FigurePlot).show(Figure(empty_message="computing the root locus ..."))

        parameter = self.locus_parameter

        def compute() -> None:
            figure = locus_figure(view, parameter)
            self.app.call_from_thread(self._show_locus, key, figure)

        self.run_worker(compute, thread=True, exclusive=True, group="locus")

    def action_locus_parameter(self) -> None:
        """Choose what the root locus varies, the loop gain or one parameter, and show the
        locus: History's plot when that tab is shown, else the Run tab's."""
        from tui.screens.dialogs import ChooseDialog

        names = [p.name for p in self.bench.session.problem.parameters]
        choices = [("gain", "the loop gain k (1 + k L = 0)")] + [
            (n, "this parameter, a decade either side") for n in names
        ]

        def chosen(name: str | None) -> None:
            if not name:
                return
            self.locus_parameter = name
            if self.query_one("#tabs").active == "history":
                self.query_one("#history-pane").show_view("locus")
                return
            self.query_one("#plots").active = "p-locus"
            self.refresh_locus()

        self.app.push_screen(ChooseDialog("root locus in", choices), chosen)

    def _show_locus(self, key, figure: Figure) -> None:
        if key == self._locus_key:
            self.query_one("#locus", FigurePlot).show(figure)

"""The workbench screen: Run (plots and tableau), Plant, Targets, History and
Sweep tabs over one `Workbench`.  The screen only reads: it draws a `View`
of the workbench; the tables' keys go through `EditFlow`, stepping through
the app's run loop."""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from rich.markup import escape
from rich.text import Text
from textual import events, on
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical, VerticalScroll
from textual.geometry import Region
from textual.message import Message
from textual.screen import Screen
from textual.widgets import DataTable, TabbedContent, TabPane

from engine.design.notes import stop_notes
from engine.stepping.presenter import Presenter, number, tolerant
from engine.stepping.protocol import StepRecord
from sessions.forms import one_line as forms
from sessions.sweeps.dispersion import PERCENTILE_KEYS, run_count
from sessions.target_use import target_note
from tui.actions.run_loop import drawings
from tui.actions.sweeps import sample_values
from tui.figures.catalog import FIGURE_IDS, applicable, figure_key
from tui.figures.data import Figure
from tui.figures.lines import sweep_figure
from tui.keys import identified
from tui.screens.history_pane import HistoryPane
from tui.screens.latest_work import FrameTimes, LatestWork
from tui.screens.pole_lines import PoleLines
from tui.screens.shaping import Shaping
from tui.screens.table_edits import TableEdits
from tui.screens.view_actions import ViewActions
from tui.state import edits
from tui.state.field_edits import objective_rows
from tui.state.matrix_grid import shown_grid
from tui.state.plant_rows import constraint_marks, plant_rows
from tui.state.tableau_text import tableau_text
from tui.state.views import View
from tui.state.workbench import Workbench
from tui.widgets.footer import Footer
from tui.widgets.matrix_table import MatrixTable
from tui.widgets.plots import FigurePlot
from tui.widgets.shape_table import ShapeTable
from tui.widgets.tables import ParametersTable, PlantTable, RefTable, SettingsTable, TargetsTable
from tui.widgets.textview import TextView

DRAGGING = "a drag: the design follows the pointer, every plot exact on release"  # the status line's edit while held
# the plot tabs, and the plots (figure ids) each shows
PLOT_TABS = {
    "p-nyquist": ("nyquist",),
    "p-bode": ("bode-mag", "bode-phase"),
    "p-nichols": ("nichols",),
    "p-closed": ("closed-loop",),
    "p-poles": ("poles",),
    "p-locus": ("locus",),
    "p-convergence": ("convergence",),
    "p-step": ("step",),
    "p-trajectories": ("trajectories",),
}
PRESENTER_PLOTS = {
    "p-nyquist": "nyquist",
    "p-bode": "bode",
    "p-nichols": "nichols",
    "p-closed": "closed_loop",
    "p-poles": "poles",
    "p-locus": "locus",
    "p-convergence": "convergence",
    "p-step": "step",
    "p-trajectories": "trajectories",
}


# each plot tab's label, and its short form where the strip is narrow (80 columns)
TAB_LABELS = {
    "p-nyquist": ("Nyquist", "Nyq"),
    "p-bode": ("Bode", "Bode"),
    "p-nichols": ("Nichols", "Nich"),
    "p-closed": ("S/T", "S/T"),
    "p-poles": ("Poles", "Pole"),
    "p-locus": ("Locus", "Loc"),
    "p-convergence": ("Convergence", "Conv"),
    "p-step": ("Step", "Step"),
    "p-trajectories": ("Trajectories", "Traj"),
}


def fitted_labels(tabs: list[str], room: int) -> tuple[list[str], bool]:
    """The plot tabs' labels that fit in ``room`` cells, and whether their padding is one cell
    (not two): the full labels when they fit, else the longest ones shortened first."""
    labels = [TAB_LABELS[tab][0] for tab in tabs]
    if sum(len(label) + 2 for label in labels) <= room:
        return labels, False
    by_saving = sorted(range(len(tabs)), key=lambda k: len(TAB_LABELS[tabs[k]][1]) - len(labels[k]))
    for k in by_saving:
        if sum(len(label) + 1 for label in labels) <= room:
            break
        labels[k] = TAB_LABELS[tabs[k]][1]
    return labels, True


def _values(value) -> str:
    """A parameter's value, or its values per condition."""
    return ", ".join(number(v) for v in value) if isinstance(value, list) else number(value)


MAIN_WIDGETS = {
    "run": "#tableau-scroll",
    "plant": "#blocks",
    "targets": "#targets-table",
    "history": "#history-table",
    "sweep": "#optima-table",
}


class MainScreen(Screen):
    """Tabs: 1 run, 2 plant, 3 targets, 4 history, 5 sweep."""

    BINDINGS = identified(
        "main",
        [
            Binding("question_mark", "app.help", "help", id="main.help"),
            Binding("ctrl+s", "app.save", "save", id="main.save"),
            Binding("p", "next_plot", "next plot", tooltip="the Run tab's next plot, or the History plot's next view"),
            Binding(
                "C",
                "shape",
                "shape",
                show=False,
                tooltip="shape the compensator by hand: its gain, zeros, poles and pairs, moved with keys",
            ),
            Binding("g", "shaping(\"gain_for('crossover')\")", "", show=False, id="main.shape_gain_for_crossover"),
            Binding("G", "shaping(\"gain_for('pm')\")", "", show=False, id="main.shape_gain_for_pm"),
            Binding("e", "shaping('type_value')", "", show=False, id="main.shape_type_value"),
            Binding("N", "shaping('notch')", "", show=False, id="main.shape_notch"),
            Binding("left_square_bracket", "shaping('damp(-1)')", "", show=False, id="main.shape_damp_down"),
            Binding("right_square_bracket", "shaping('damp(1)')", "", show=False, id="main.shape_damp_up"),
            Binding(
                "P",
                "focus_plot",
                "focus plot",
                show=False,
                tooltip="focus the plot of this tab (then + - h j k l, arrows, 0, the mouse)",
            ),
            Binding("1", "tab('run')", "run", show=False),
            Binding("2", "tab('plant')", "plant", show=False),
            Binding("3", "tab('targets')", "targets", show=False),
            Binding("4", "tab('history')", "history", show=False),
            Binding("5", "tab('sweep')", "sweep", show=False),
            Binding(
                "L",
                "locus_parameter",
                "locus in",
                show=False,
                tooltip="the root locus (Run or History) in the loop gain or a parameter",
            ),
            Binding("t", "step_setup", "step signals", show=False, tooltip="the step plot's input, output and horizon"),
            Binding(
                "y",
                "copy",
                "copy",
                show=False,
                tooltip="copy the selected table row, or the tableau (OSC 52: works over SSH)",
            ),
            Binding(
                "Y",
                "copy_design",
                "copy design",
                show=False,
                tooltip="copy the current compensator(s) as expressions with the values in place",
            ),
        ],
    )
    DEFAULT_CSS = """
    MainScreen { overflow: hidden; }
    MainScreen DataTable, #shape, #tableau-scroll { border-left: blank; }
    MainScreen DataTable:focus, #shape:focus, #tableau-scroll:focus { border-left: thick $accent; }
    #plots { min-width: 37; margin-right: 1; }  /* a column between the plot tabs and the tableau */
    #status { height: auto; max-height: 2; background: $boost; padding: 0 1; }
    #refused { display: none; text-wrap: wrap; background: $boost; padding: 0 1; text-style: bold; }
    #refused.shown { display: block; }
    #tabs { height: 1fr; }
    #tabs > ContentSwitcher { height: 1fr; }
    #plots > ContentSwitcher { height: 1fr; }
    #plots { width: 3fr; }
    #plots.tight Tab { padding: 0 0 0 1; }  /* `fitted_labels` */
    #sweep-status { text-wrap: wrap; }  /* the study's line wraps: nothing of it off screen */
    #tableau-side { width: 2fr; min-width: 42; }  /* 41 columns of tableau beside the focus bar */
    #tableau-scroll { height: 1fr; }
    #tableau { height: auto; }
    #step-info { height: 6; }
    #shape { height: auto; max-height: 9; display: none; }
    #shape.shown { display: block; }
    #bode-mag, #bode-phase { height: 1fr; }
    #blocks, #matrix-grid, #parameters, #targets-table, #objective-table { height: 1fr; }
    """

    class FiguresDrawn(Message):
        """The figures of the plots on screen for the view of ``key`` (a thread worker's, or
        a drag's frame drawn inline); ``frame_s``: how long a drag's frame took to draw."""

        def __init__(self, key: tuple, drawn: dict, prebuilt: dict, frame_s: float | None = None) -> None:
            super().__init__()
            self.key, self.drawn, self.prebuilt, self.frame_s = key, drawn, prebuilt, frame_s

    def __init__(self, bench: Workbench):
        super().__init__()
        self.bench = bench
        self._stale = {"plant", "targets", "history", "sweep"}  # tabs redrawn when next shown
        self._figure_keys: dict[str, tuple] = {}  # plot id -> the `figure_key` of the view it shows
        self.refused = ""  # why the key just pressed cannot act, under the status line (`say_refused`)
        self.dragged_plot: str | None = None  # a drag goes on this plot: the others wait for its release
        self.frame_times = FrameTimes()  # a drag's frame drawn at once when the plot's last was quick
        self.pole_lines = PoleLines(self)  # the closed-loop poles under the tableau
        self.figure_work = LatestWork(self, "figures")  # the plots' figures, the latest design's alone
        self.view_actions = ViewActions(self)  # the step plot's signals, copies, the root locus
        self.shaping = Shaping(self)  # the shaping table's requests applied to the session
        self.table_edits = TableEdits(self)  # the other tables' requests applied to the session
        self._frozen: list[RefTable | MatrixTable | ShapeTable] = []  # the tables whose keys a run disables
        self._shown_plots: list[FigurePlot] = []  # the plots on the tabs (`on_mount`), History's apart
        self._after_paint: list[Callable[[], None]] = []  # workers' starts held for the next paint
        self._painted = False  # the held starts run: the screen has just painted (`after_paint`)

    def compose(self) -> ComposeResult:
        yield TextView("", id="status")
        yield TextView("", id="refused")  # why a key cannot act (`say_refused`)
        with TabbedContent(id="tabs", initial="run"):
            with TabPane("Run", id="run"):
                with Horizontal():
                    yield from self._plots()
                    with Vertical(id="tableau-side"):
                        with VerticalScroll(id="tableau-scroll"):
                            yield TextView("", id="tableau", keep_height=True)
                        yield ShapeTable(id="shape")
                        yield TextView("", id="step-info")
            with TabPane("Plant", id="plant"):
                with Vertical():
                    yield PlantTable(id="blocks")
                    yield MatrixTable(id="matrix-grid")
                    yield ParametersTable(id="parameters")
            with TabPane("Targets", id="targets"):
                with Vertical():
                    yield TargetsTable(id="targets-table")
                    yield SettingsTable(id="objective-table")
            with TabPane("History", id="history"):
                yield HistoryPane(id="history-pane")
            with TabPane("Sweep", id="sweep"):
                with Horizontal():
                    yield FigurePlot(id="sweep-plot")
                    with Vertical(id="sweep-side"):
                        yield TextView("", id="sweep-status")
                        yield DataTable(id="optima-table", cursor_type="row")
        yield Footer()

    def _plots(self) -> ComposeResult:
        """The plot tabs that apply to the algorithm (its presenter's `plots`)."""
        wanted = applicable(self.bench.book.presenter.plots, self.bench.session.problem)
        self.plot_tabs = [tab for tab in PLOT_TABS if PRESENTER_PLOTS[tab] in wanted]
        with TabbedContent(id="plots"):
            for tab in self.plot_tabs:
                with TabPane(TAB_LABELS[tab][0], id=tab):
                    if tab == "p-bode":
                        with Vertical():
                            yield FigurePlot(id="bode-mag")
                            yield FigurePlot(id="bode-phase")
                    else:
                        yield FigurePlot(id=PLOT_TABS[tab][0])

    def on_mount(self) -> None:
        for table in self.query(RefTable):
            table.allows = self.table_edits.allows
        self._frozen = [*self.query(RefTable), self.query_one(MatrixTable), self.query_one(ShapeTable)]
        # the plots a run or an edit draws (composed once: a query walks every widget of every tab)
        self._shown_plots = [plot for plot in self.query(FigurePlot) if plot.id != "history-plot"]
        self.app.refresh_workbench()

    def after_paint(self, start: Callable[[], None]) -> None:
        """Call ``start`` (a thread worker's start, what the first paint can do without) once
        the screen has painted what the handler changed: a thread started in the handler holds
        the GIL half the time while the UI thread paints (a nudge's tableau took about twice its
        CPU time).  At once when this screen is painted no more (covered: Textual's
        `is_current` is False), or when the held starts run (it has just painted)."""
        if not self.is_current or self._painted:
            start()
            return
        self._after_paint.append(start)
        self.query_one("#tableau", TextView).refresh(Region(0, 0, 1, 1))  # a paint is sure to come (a cell's)

    def _compositor_refresh(self) -> None:
        """Textual's paint of the screen, then the workers' starts held for it."""
        super()._compositor_refresh()
        self._start_held()

    @on(events.ScreenSuspend)
    def _start_held(self) -> None:
        """Start the workers held for a paint (after one, or when another screen is pushed:
        two pushed before the next paint would cover it for good)."""
        held, self._after_paint = self._after_paint, []
        self._painted = True
        try:
            for start in held:
                start()
        finally:
            self._painted = False

    def on_resize(self, event) -> None:
        """The tableau's layout follows its width (compact below 58 columns), the plot tabs'
        labels theirs (`fitted_labels`), the status line its (`refresh_status`: short when narrow)."""
        self.call_after_refresh(lambda: self.refresh_run(plots=False))
        self.call_after_refresh(self._fit_plot_tabs)
        self.call_after_refresh(self.refresh_status)

    def _fit_plot_tabs(self) -> None:
        """The plot tabs' labels, shortened where the strip is too narrow for them."""
        plots = self.query_one("#plots", TabbedContent)
        labels, tight = fitted_labels(self.plot_tabs, plots.size.width)
        plots.set_class(tight, "tight")
        for tab, label in zip(self.plot_tabs, labels):
            if plots.get_tab(tab).label_text != label:
                plots.get_tab(tab).label = label

    def action_next_plot(self) -> None:
        """The next plot of the Run tab, or the History plot's next view."""
        if self.query_one("#tabs", TabbedContent).active == "history":
            self.query_one(HistoryPane).action_next_view()
            return
        plots = self.query_one("#plots", TabbedContent)
        tabs = self.plot_tabs
        on_plot = isinstance(self.focused, FigurePlot)
        plots.active = tabs[(tabs.index(plots.active) + 1) % len(tabs)] if plots.active in tabs else tabs[0]
        self.refresh_plots()
        if on_plot:  # the focus stays on the plots: on the one shown now
            self.call_after_refresh(self.action_focus_plot)

    def action_shape(self) -> None:
        """Show the shaping table under the tableau (Run tab) and focus it; again: hide it."""
        table = self.query_one("#shape", ShapeTable)
        if table.has_class("shown") and table.has_focus:
            table.remove_class("shown")
            self.focus_main("run")
            return
        self.show_shape()

    def show_shape(self) -> ShapeTable:
        """The shaping table shown on the Run tab, filled from the current design, focused."""
        table = self.query_one("#shape", ShapeTable)
        self.action_tab("run")
        if not table.has_class("shown"):
            table.add_class("shown")
            self.fill_shape()
        self.set_focus(table)
        return table

    async def action_shaping(self, action: str) -> None:
        """A shaping key pressed anywhere on the Run tab: it acts on the shaping table's
        selected item (the table shown and focused first); one that cannot act says why."""
        await self.app.run_action(action, self.show_shape())

    def fill_shape(self, view: View | None = None) -> None:
        """The shaping table's rows from the current design, when it is shown."""
        table = self.query_one("#shape", ShapeTable)
        if table.has_class("shown"):
            table.fill(edits.compensator_rows(self.bench.view() if view is None else view))

    @on(ShapeTable.Request)
    def _shaping_requested(self, request: ShapeTable.Request) -> None:
        self.shaping.handle(request)

    @on(RefTable.Request)
    def _table_requested(self, request: RefTable.Request) -> None:
        self.table_edits.handle(request)

    @on(MatrixTable.EditCell)
    def _cell_requested(self, message: MatrixTable.EditCell) -> None:
        self.table_edits.matrix_cell(message)

    def tab_plot(self) -> FigurePlot | None:
        """The plot of the tab shown (the Run tab's: the first of its plot tab), if any."""
        tabs = self.query_one_optional("#tabs", TabbedContent)
        where = {"run": None, "history": "#history-plot", "sweep": "#sweep-plot"}.get(tabs.active if tabs else "", "")
        if where is None:
            pane = self.query_one("#plots", TabbedContent).active
            where = f"#{PLOT_TABS[pane][0]}" if pane in PLOT_TABS else ""
        return self.query_one(where, FigurePlot) if where else None

    def action_focus_plot(self) -> None:
        plot = self.tab_plot()
        if plot is not None:
            self.set_focus(plot)

    # -- the parts' actions and what their workers post back -------------------

    def action_step_setup(self) -> None:
        self.view_actions.step_setup()

    def action_copy(self) -> None:
        self.view_actions.copy()

    def action_copy_design(self) -> None:
        self.view_actions.copy_design()

    def action_locus_parameter(self) -> None:
        self.view_actions.choose_locus_parameter()

    @on(LatestWork.Done)
    def _work_done(self, message: LatestWork.Done) -> None:
        message.work.done()
        if message.error is not None:
            self.notify(message.error, title=f"cannot draw ({message.work.group})", severity="error", timeout=10)

    @on(ViewActions.LocusDrawn)
    def _locus_drawn(self, message: ViewActions.LocusDrawn) -> None:
        self.view_actions.locus_drawn(message)

    @on(PoleLines.Found)
    def _poles_found(self, message: PoleLines.Found) -> None:
        self.pole_lines.found(message)

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """p and L are disabled where they have nothing to show."""
        tabs = self.query_one_optional("#tabs", TabbedContent)  # (query_one is cached; a query's truth walks the DOM)
        history = tabs is not None and tabs.active == "history"
        if action == "next_plot" and history:
            return self.query_one(HistoryPane).check_action("next_view", parameters)
        if action == "focus_plot":
            return True if self.tab_plot() is not None else None
        if action == "shaping":
            return True if tabs is not None and tabs.active == "run" else None
        if action == "locus_parameter":
            there = (
                "locus" in self.query_one(HistoryPane).views()
                if history
                else "p-locus" in getattr(self, "plot_tabs", [])
            )
            return True if there else None
        return True

    def disabled_reason(self, action: str) -> str | None:
        """Why a screen key cannot act now."""
        if action == "focus_plot":
            return "no plot on this tab (Run, History and Sweep have one)"
        if action == "locus_parameter":
            return "no root locus here: it needs a rational loop (no table, no delay) and a loop-plot session"
        if action == "shaping":
            return "the shaping keys act on the Run tab (1, then C shows the shaping table)"
        return None

    def action_tab(self, name: str) -> None:
        """Show a tab and focus its main widget (focus left in a hidden pane would
        make the tabs switch back to it)."""
        self.query_one("#tabs", TabbedContent).active = name
        self.focus_main(name)

    def focus_main(self, name: str) -> None:
        """Focus the main widget of a tab: its first table, or on the Run tab the shaping
        table when it is shown, else the tableau."""
        shape = self.query_one("#shape", ShapeTable)
        self.set_focus(shape if name == "run" and shape.has_class("shown") else self.query_one(MAIN_WIDGETS[name]))

    def on_tabbed_content_tab_activated(self, event: TabbedContent.TabActivated) -> None:
        if event.tabbed_content.id == "plots":
            self.view_actions.refresh_locus()
        if event.tabbed_content.id != "tabs":
            return
        self.refresh_bindings()
        self.refresh_shown()
        pane = event.tabbed_content.active
        focused = self.focused
        if focused is None or pane not in [a.id for a in focused.ancestors_with_self]:
            self.focus_main(pane)

    # -- refreshing ---------------------------------------------------------

    def refresh_all(self, plots: bool = True) -> None:
        """Everything from the session: the Run tab now and the status line once it is
        painted (in one paint, the status line's row at the top stretched the box Textual
        paints over the tab bar: a dozen more widgets rendered), the tab shown if another, the
        hidden ones when they are shown (a nudge redraws no hidden table)."""
        view = self.bench.view()
        self.after_paint(self.refresh_status)
        self.refresh_run(view, plots=plots)
        self._stale |= {"plant", "targets", "history", "sweep"}
        self.refresh_shown(view)
        self.refresh_bindings()

    def refresh_shown(self, view: View | None = None) -> None:
        """The tab shown, when it is stale (the Run tab never is: `refresh_run`)."""
        pane = self.query_one("#tabs", TabbedContent).active
        if pane not in self._stale:
            return
        if pane == "history":
            self.refresh_history(view)
        else:
            {"plant": self.refresh_plant, "targets": self.refresh_targets, "sweep": self.refresh_sweep}[pane]()

    def say_refused(self, text: str) -> None:
        """The line under the status says why the key just pressed cannot act (``text``,
        wrapped: whole at 80 columns), shown until the next key ("": hidden)."""
        if text != self.refused:
            self.refused = text
            line = self.query_one("#refused", TextView)
            line.set(Text(text))
            line.set_class(bool(text), "shown")

    def refresh_status(self) -> None:
        b = self.bench
        name = b.session.path.name if b.session.path else "untitled"
        mark = " *" if b.dirty else ""
        busy = "  [b]stepping[/b] (space pauses)" if self.app.busy else ""
        for table in self._frozen:  # the tables' keys that change the session: disabled while work goes
            table.frozen = self.app.busy
        last = DRAGGING if self.dragged_plot is not None else b.edits.last  # one text a drag: no repaint a move
        edit = f"  [dim]{escape(last)}[/dim]" if last else ""
        status = self.query_one("#status", TextView)
        head = f"[b]{escape(name)}{mark}[/b]  algorithm [b]{escape(b.algorithm_name)}[/b]  Iteration {b.iteration}  "
        text = f"{head}{escape(b.status_text())}{busy}"
        if status.size.width and Text.from_markup(text).cell_len > status.content_size.width:
            # narrow (80 columns): the keys the footer shows and the word "algorithm" go first, the state stays whole
            head = f"[b]{escape(name)}{mark}[/b]  [b]{escape(b.algorithm_name)}[/b]  Iteration {b.iteration}  "
            text = f"{head}{escape(b.status_text(hints=False))}{'  [b]stepping[/b]' if busy else ''}"
        status.set(text + edit)

    def refresh_run(self, view: View | None = None, plots: bool = True) -> None:
        """The tableau, the lines under it and (with ``plots``) the plots, drawn in a
        worker (`draw_missing`; a run's worker draws its own: `show_drawn`) asked once the
        tableau is painted (a drag's dragged plot at once: its frame)."""
        view = self.bench.view() if view is None else view
        record = self.refresh_tableau(view)
        self.query_one("#step-info", TextView).set(self._step_info(view, record))
        self.fill_shape(view)
        if plots and self.dragged_plot is not None:
            self.refresh_plots(view)
        elif plots:
            self.after_paint(self.refresh_plots)

    def refresh_tableau(self, view: View | None = None) -> StepRecord | None:
        """The tableau with the lines under it (what binds at a stop, the closed-loop
        poles); its record."""
        view = self.bench.view() if view is None else view
        rows, record = view.tableau()
        previous = view.tableau(view.iteration - 1)[0] if view.iteration > 0 else []
        unit = view.problem.grid.unit
        width = self.query_one("#tableau-scroll").size.width or None
        text = tableau_text(rows, previous, unit, width)
        stops = (
            [] if record is None else stop_notes(view.problem, record.status, dict(record.parameters), record.measures)
        )
        if stops:  # a finished run: what binds, what sits at a bound, what is unmet
            text.append("\n" + "\n".join(f"stop: {note}" for note in stops) + "\n")
        poles = self.pole_lines.text(view)
        if poles:
            text.append("\n" + poles + "\n")
        self.query_one("#tableau", TextView).set(text)
        return record

    def canvases(self) -> dict[str, tuple[int, int, str]]:
        """The size and theme of every plot that is on screen now (UI thread)."""
        out = {}
        for plot in self._shown_plots:
            if plot.display and plot.size.width > 0 and plot.region.width > 0:
                out[plot.id] = plot.canvas()
        return out

    def refresh_plots(self, view: View | None = None) -> None:
        """The plots on screen that are not of the current view, drawn in a worker
        (`draw_missing`); the root locus and History's plot as their tabs ask."""
        view = self.bench.view() if view is None else view
        self.draw_missing(view)
        self.view_actions.forget_locus()
        self.view_actions.refresh_locus(view)
        if self.query_one("#tabs", TabbedContent).active == "history":
            self.query_one(HistoryPane).show_iteration(self.query_one(HistoryPane).selected, view)

    def draw_missing(self, view: View | None = None) -> None:
        """The plots on screen whose figures are not of the current view (while a drag
        goes, the dragged one alone: `dragged_plot`), computed in a thread worker (a
        tabulated loop's fit takes a second) and shown when done; a newer request
        replaces one waiting (`LatestWork`), started once the screen has painted (a drag's
        at once, or a drag's quick frame drawn right here: `FrameTimes`).  A plot never
        drawn says it is computing."""
        view = self.bench.view() if view is None else view
        key, canvases = self._wanted_key(view), self.canvases()
        coarse = self.dragged_plot is not None
        if coarse:  # while dragging, the dragged plot alone follows, coarse (`figures`)
            canvases = {name: canvas for name, canvas in canvases.items() if name == self.dragged_plot}
        missing = {name for name in canvases if name in FIGURE_IDS and self._figure_keys.get(name) != key}
        if not missing:
            return
        held = {}
        for name in missing:
            plot = self.query_one(f"#{name}", FigurePlot)
            held[name] = plot.held()
            if name not in self._figure_keys:
                plot.show(Figure(empty_message="computing ..."))

        def figures() -> MainScreen.FiguresDrawn:  # (Bode's panels come as a pair: the one not asked for is left)
            began = time.thread_time()  # the drawing's own time, not the paints it waited on
            drawn, prebuilt = drawings(view, canvases, missing, held, coarse)
            took = time.thread_time() - began if coarse else None
            return self.FiguresDrawn(key, {n: f for n, f in drawn.items() if n in missing}, prebuilt, took)

        def start() -> None:
            self.figure_work.request(lambda: self.post_message(figures()), (key, frozenset(missing)))

        if coarse and self.frame_times.at_once(missing, self.figure_work):  # painted with the tableau
            try:
                self._figures_drawn(figures())
            except Exception:  # noqa: BLE001 - the worker draws it again and says what failed (`LatestWork`)
                self.frame_times.took(missing, math.inf)
                start()
        elif coarse:  # a frame too slow to draw inline: computed while the tableau paints
            start()
        else:  # a nudge's tableau painted first, then the plots (`after_paint`)
            self.after_paint(start)

    @on(FigurePlot.Chosen)
    def _plot_chosen(self, message: FigurePlot.Chosen) -> None:
        if message.plot.id == "locus":  # enter on the root locus: the design takes the gain there
            self.view_actions.adopt_locus_value(float(message.value))

    @on(FigurePlot.AskValue)
    def _plot_value_asked(self, message: FigurePlot.AskValue) -> None:
        self.view_actions.go_to(message.plot)

    @on(FigurePlot.Dragged)
    def _plot_dragged(self, message: FigurePlot.Dragged) -> None:
        self.shaping.drag(message)

    @on(FigurePlot.Navigated)
    def _plot_navigated(self, message: FigurePlot.Navigated) -> None:
        """Bode's two panels are linked: zoom, pan and the cursor of one, the other's too."""
        linked = {"bode-mag": "#bode-phase", "bode-phase": "#bode-mag"}.get(message.plot.id or "")
        if linked is not None:
            self.query_one(linked, FigurePlot).follow(message.plot)

    @on(FigurePlot.Shown)
    def _plot_shown(self) -> None:
        """A plot that comes on screen (its tab, either level, shown) is drawn anew when its
        figure is of an earlier design: a run finished, or an edit made, while it was hidden."""
        self.call_after_refresh(self.draw_missing)

    def redraw_released(self, plot: FigurePlot) -> None:
        """A dragged plot after the release, its view given back: drawn again now unless
        a figure of the design is on its way (`draw_missing`: drawing the coarse figure in
        the view given back first was a draw on the UI thread, 60 ms, before the release's edit)."""
        coming = plot.id in FIGURE_IDS and self._figure_keys.get(plot.id) != self._wanted_key(self.bench.view())
        if not coming:
            plot.refresh()

    def _wanted_key(self, view: View) -> tuple:
        """The key the plots on screen should show: the view's `figure_key`, a drag's coarse
        frame's apart (its release draws the plots anew, exact)."""
        key = figure_key(view)
        return key if self.dragged_plot is None else (*key, "coarse")

    @on(FiguresDrawn)
    def _figures_drawn(self, message: FiguresDrawn) -> None:
        if message.frame_s is not None:
            self.frame_times.took(set(message.drawn), message.frame_s)
        if message.key == self._wanted_key(self.bench.view()):
            self._show_figures(message.key, message.drawn, message.prebuilt)

    def show_drawn(self, key: tuple, drawn: dict, prebuilt: dict) -> None:
        """A run's plots, when they are of the current view; then any other plot on screen."""
        view = self.bench.view()
        if key == figure_key(view):
            self._show_figures(key, drawn, prebuilt)
            self.draw_missing(view)

    def _show_figures(self, key: tuple, drawn: dict, prebuilt: dict | None) -> None:
        for name, figure in drawn.items():
            for plot in self.query(f"#{name}").results(FigurePlot):
                plot.show(figure, (prebuilt or {}).get(name))
                self._figure_keys[name] = key

    def _step_info(self, view: View, record: StepRecord | None) -> str | Text:
        if record is None or record.iteration == 0:
            return "no iterations yet: [b]s[/b] steps, [b]r[/b] runs, [b]?[/b] help"
        lines = tolerant(
            lambda: view.presenter.status_lines(record), lambda: Presenter.status_lines(view.presenter, record)
        )
        return Text("\n".join(lines + [f"note: {n}" for n in self.bench.design_notes(record)]))

    def refresh_plant(self) -> None:
        self._stale.discard("plant")
        model = self.bench.session.model.problem
        self.query_one("#blocks", PlantTable).fill(
            ("condition", "block", "input", "output", "kind", "definition"),
            plant_rows(model, self.bench.session.problem),
        )
        self.query_one("#matrix-grid", MatrixTable).fill(shown_grid(model, self.bench.plotted_condition))
        free = {p.name: p.free for p in self.bench.session.problem.parameters}
        marks = constraint_marks(self.bench.session.problem, self.bench.constraint_states())
        records = self.bench.records
        current = records[-1].parameters if records else {}
        rows = []
        for k, p in enumerate(model.parameters):
            state = "free" if free.get(p.name, p.free) else ("held" if p.free else "fixed")
            now = current.get(p.name, p.value)
            rows.append(
                (
                    (
                        p.name,
                        _values(now),
                        _values(p.value) if records else "",
                        number(p.min),
                        number(p.max),
                        state,
                        "yes" if isinstance(p.value, list) else "shared",
                        marks.get(p.name, ""),
                    ),
                    ("parameters", k),
                )
            )
        self.query_one("#parameters", ParametersTable).fill(
            (
                "parameter",
                f"value (iteration {len(records)})" if records else "value",
                "start" if records else "",
                "min",
                "max",
                "free",
                "per condition",
                "constraints",
            ),
            rows,
        )

    def refresh_targets(self) -> None:
        self._stale.discard("targets")
        model = self.bench.session.model.problem
        rows = []
        for k, t in enumerate(model.targets):
            points = forms.format_points(t.points) or "default"
            detect = forms.format_range((t.detect_low, t.detect_high))
            use = target_note(t.measure, self.bench.algorithm_name) or "yes"
            rows.append(
                (
                    (
                        t.measure,
                        use,
                        t.condition or "all",
                        forms.format_bands(t.bands),
                        points,
                        number(t.weight),
                        detect,
                        t.unit,
                    ),
                    ("targets", k),
                )
            )
        self.query_one("#targets-table", TargetsTable).fill(
            (
                "measure",
                "used",
                "condition",
                "bands (low..high: desired / required)",
                "points",
                "weight",
                "detect",
                "unit",
            ),
            rows,
        )
        self.query_one("#objective-table", SettingsTable).fill(
            ("objective / setting", "value"),
            [((label, value), ref) for label, value, ref in objective_rows(self.bench)],
        )

    def refresh_history(self, view: View | None = None) -> None:
        """The history table, rebuilt only while its tab is shown (else on the next visit)."""
        if self.query_one("#tabs", TabbedContent).active != "history":
            self._stale.add("history")
            return
        self._stale.discard("history")
        self.query_one(HistoryPane).fill(self.bench.view() if view is None else view)

    def refresh_sweep(self, progress: str | None = None) -> None:
        """The latest sweep: status line, its optima (or worst case) and its plot."""
        if progress is not None:
            self.query_one("#sweep-status", TextView).set(Text(progress))
            return
        self._stale.discard("sweep")
        sweep = self.bench.sweeps.latest()
        table = self.query_one("#optima-table", DataTable)
        table.clear(columns=True)
        status = "no sweep yet.  [b]w[/b] starts one (starts 16 | vary NAME=V1,V2 | tolerance NAME=+-10%)"
        if sweep:
            status = (
                f"{escape(str(sweep['kind']))} sweep of {escape(str(sweep['created']))}: {run_count(sweep)} on {sweep['workers']} "
                f"worker(s), {len(sweep['failed'])} failed, {len(sweep['retried'])} retried"
                + (", cancelled" if sweep["cancelled"] else "")
                + (
                    ".\nThe plot: the highlighted row's histogram; [b]u[/b] opens its worst sample"
                    if sweep["kind"] == "tolerance"
                    else ".  [b]u[/b] uses the best optimum"
                )
            )
            _fill_sweep(table, sweep)
        self.query_one("#sweep-status", TextView).set(status)
        self.query_one("#sweep-plot", FigurePlot).show(sweep_figure(sweep, self.sweep_row()))

    def sweep_row(self) -> int:
        """The row highlighted in the Sweep tab's table (0 when none)."""
        return max(self.query_one("#optima-table", DataTable).cursor_row, 0)

    @on(DataTable.RowHighlighted, "#optima-table")
    def _sweep_row_highlighted(self) -> None:
        """A tolerance study's plot follows its table: the histogram of the row highlighted."""
        sweep = self.bench.sweeps.latest()
        if sweep is not None and sweep["kind"] == "tolerance":
            self.query_one("#sweep-plot", FigurePlot).show(sweep_figure(sweep, self.sweep_row()))


def _fill_sweep(table: DataTable, sweep: dict) -> None:
    """The worst case of a tolerance sweep, or the optima of the others."""
    if sweep["kind"] == "tolerance":
        table.add_columns(
            "measure",
            "condition",
            "worst",
            "target",
            "unmet/samples",
            "unmet % [95 %]",
            *PERCENTILE_KEYS,
            "worst sample",
        )
        for w in sweep["worst_case"]:
            table.add_row(
                w["name"],
                w["condition"],
                number(w["worst"], 5),
                number(w["desired"], 4),
                f"{w['unmet_samples']}/{w['samples']}",
                *_distribution_cells(w),
            )
        return
    table.add_columns("optimum", "count", "meets", "ranking", "best run", "parameters")
    for k, o in enumerate(sweep["optima"], start=1):
        params = "  ".join(
            f"{n}={number(v if not isinstance(v, list) else v[0], 4)}" for n, v in o["parameters"].items()
        )
        table.add_row(
            str(k),
            str(o["count"]),
            "yes" if o["meets_requirements"] else "no",
            number(o["ranking"], 6),
            str(o["best_run"]),
            params,
        )


def _distribution_cells(row: dict) -> list[str]:
    """A worst-case row's unmet fraction with its interval, percentiles and worst sample
    (blank for a row of a study saved without them)."""
    if row.get("percentiles") is None:
        return [""] * (len(PERCENTILE_KEYS) + 2)
    low, high = row["unmet_interval"]
    return [
        f"{100 * row['unmet_fraction']:.1f} [{100 * low:.1f}, {100 * high:.1f}]",
        *(number(row["percentiles"].get(key), 5) for key in PERCENTILE_KEYS),
        f"{row['worst_sample']}: {sample_values(row['worst_parameters'])}",
    ]

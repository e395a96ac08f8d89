"""The History tab: every iteration (the earlier runs and hand moves above, one
line each); the selected one's design in one view
(`tui.figures.history`: Nyquist, Bode, phase, Nichols, S/T, poles, locus,
step) beside the marked iteration or the current design, and its tableau (or
its measures against the marked one's).

A figure is computed in a thread worker, one at a time (`LatestWork`): the
worker posts it back (`Drawn`) and the latest request waiting is computed next,
so moving through the rows never piles up work (a tabulated loop's S/T takes seconds).
Figures are kept until the problem changes.  Zoom, pan and the cursor are
the plot's own (`FigurePlot`); they reset when the view changes."""

from __future__ import annotations

from collections.abc import Callable

from rich.text import Text
from textual import on
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical, VerticalScroll
from textual.message import Message
from textual.widget import Widget
from textual.widgets import DataTable

from engine.stepping.presenter import number, tolerant
from sessions.compare import compare, comparison_text, side
from sessions.hand_history import earlier_lines
from tui.figures.data import Figure
from tui.figures.history import TITLES, VIEWS, figure_key, history_figure, history_views, name
from tui.keys import identified
from tui.screens.latest_work import LatestWork
from tui.state.tableau_text import tableau_text
from tui.state.views import View
from tui.widgets.plots import FigurePlot
from tui.widgets.tables import HistoryTable
from tui.widgets.textview import TextView

KEPT_FIGURES = 64  # computed figures kept (for going back to a row)
PLACEHOLDER_AFTER = 0.15  # s: a figure not drawn by then shows 'computing ...'


class ViewsLine(Widget):
    """The History plot's views in one line, the shown one highlighted (its title alone
    with its place when the line is too narrow for all)."""

    DEFAULT_CSS = "ViewsLine { height: 1; }"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.views: list[str] = []
        self.current = ""

    def set(self, views: list[str], current: str) -> None:
        self.views, self.current = views, current
        self.refresh()

    def render(self) -> Text:
        if not self.views:
            return Text("no views of a design here", style="dim")
        line = Text()
        for kind in self.views:
            title = VIEWS[kind][0]
            line.append(
                f" {title} " if kind == self.current else f"{title} ",
                style="reverse bold" if kind == self.current else "dim",
            )
        if line.cell_len <= self.size.width or self.current not in self.views:
            return line
        at = self.views.index(self.current) + 1
        return Text.assemble(
            (f" {VIEWS[self.current][0]} ", "reverse bold"), (f" {at}/{len(self.views)}  p: next view", "dim")
        )


class HistoryPane(Horizontal):
    """The history table beside the selected iteration's plot and tableau."""

    BINDINGS = identified(
        "history",
        [
            Binding("m", "mark", "mark", tooltip="mark it: the others are compared with it (m again: unmark)"),
            Binding(
                "o", "next_view", "view", show=False, tooltip="the History plot's next view (those that apply; p too)"
            ),
        ],
    )
    DEFAULT_CSS = """
    HistoryPane #history-table, HistoryPane #history-side { height: 1fr; }
    HistoryPane #history-plot { height: 2fr; }
    HistoryPane #history-scroll { height: 1fr; }
    HistoryPane #history-earlier { height: auto; max-height: 6; }
    """

    class Drawn(Message):
        """A worker's figure for a request (`HistoryPane.key`)."""

        def __init__(self, key: tuple, figure: Figure, problem):
            super().__init__()
            self.key, self.figure, self.problem = key, figure, problem

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.compare_mark: int | None = None  # the iteration the others are compared with
        self.kind = "nyquist"  # the view shown
        self._kept: dict[tuple, Figure] = {}
        self._kept_for = None  # the problem the kept figures are of
        self.figure_work = LatestWork(self, "history-figure")  # one figure at a time, the latest waiting
        self._latest: tuple | None = None  # the key of the figure wanted on screen
        self._shown: tuple | None = None  # the key of the figure on screen
        self._shown_kind = ""

    def compose(self) -> ComposeResult:
        yield HistoryTable(id="history-table")
        with Vertical(id="history-side"):
            yield TextView("", id="history-earlier")
            yield ViewsLine(id="history-views")
            yield FigurePlot(id="history-plot")
            with VerticalScroll(id="history-scroll"):
                yield TextView("", id="history-tableau")

    @property
    def bench(self):
        return self.app.bench

    # -- what is shown -------------------------------------------------------

    def views(self) -> list[str]:
        """The views that apply to the session's designs."""
        return history_views(self.bench.book.presenter.plots, self.bench.session.problem)

    def fill(self, view: View) -> None:
        """The table of iterations (the selected row kept), then its plot and tableau."""
        label, its, values = view.convergence()
        value_at = dict(zip(its, values))
        rows = [(("0", "start", "", ""), (0,))]
        rows += [
            (
                (
                    str(r.iteration),
                    r.status.value,
                    number(value_at.get(r.iteration), 6),
                    str(sum(not m.satisfied for m in r.measures)),
                ),
                (r.iteration,),
            )
            for r in view.records
        ]
        table = self.query_one(HistoryTable)
        table.fill(("iteration", "status", label or "value", "unmet"), rows)
        earlier = self.query_one("#history-earlier", TextView)
        lines = earlier_lines(self.bench.session)
        earlier.set(Text("\n".join(lines), style="dim"))
        earlier.display = bool(lines)
        self.show_iteration(max(table.cursor_row, 0), view)

    def show_iteration(self, iteration: int, view: View | None = None) -> None:
        """The selected iteration's view (beside the current design, or the marked
        iteration) and its tableau (or its measures against the marked one's)."""
        view = self.bench.view() if view is None else view
        iteration = min(iteration, view.iteration)  # the table may not be refilled yet (an undo)
        marked = self.compare_mark if self.compare_mark is not None and self.compare_mark <= view.iteration else None
        self._tableau(view, iteration, marked)
        views = history_views(view.presenter.plots, view.problem)
        if self.kind not in views and views:
            self.kind = views[0]
        self.query_one(ViewsLine).set(views, self.kind)
        if not views:
            self._show(("none",), Figure(empty_message="no views of a design: the session has no loop"))
            return
        kind, parameter = self.kind, self.screen.view_actions.locus_parameter
        self.request(
            view,
            figure_key(view, iteration, marked, kind, parameter),
            lambda: history_figure(view, iteration, marked, kind, parameter),
            f"{TITLES[kind]} of {name(iteration)}",
        )

    def _tableau(self, view: View, iteration: int, marked: int | None) -> None:
        text = None
        if marked is not None and marked != iteration:
            session = self.bench.session
            text = tolerant(
                lambda: comparison_text(
                    compare(
                        side(session, marked, f"iteration {marked}"), side(session, iteration, f"iteration {iteration}")
                    )
                ),
                lambda: None,
            )
        if text is None:
            rows, _ = view.tableau(iteration)
            self.query_one("#history-tableau", TextView).set(tableau_text(rows, [], view.problem.grid.unit))
        else:
            self.query_one("#history-tableau", TextView).set(Text(text))

    @property
    def selected(self) -> int:
        """The selected row's iteration."""
        return max(self.query_one(HistoryTable).cursor_row, 0)

    # -- figures, computed off the UI thread -------------------------------------

    def request(self, view: View, key: tuple, build: Callable[[], Figure], what: str) -> None:
        """Show the figure ``build`` makes: kept, being computed, or computed next."""
        if view.problem is not self._kept_for:
            self._kept, self._kept_for = {}, view.problem
        self._latest = key
        if key == self._shown:
            return
        if key in self._kept:
            self._show(key, self._kept[key])
            return
        problem = view.problem

        def compute() -> None:
            try:
                figure = build()
            except Exception as exc:  # noqa: BLE001 - a figure that cannot be made must not end the app
                figure = Figure(empty_message=f"cannot draw it: {type(exc).__name__}: {exc}")
            self.post_message(self.Drawn(key, figure, problem))

        self.figure_work.request(compute, key)
        self.set_timer(PLACEHOLDER_AFTER, lambda: self._placeholder(key, what))

    def _placeholder(self, key: tuple, what: str) -> None:
        """'computing ...' while the latest request is not drawn."""
        if key == self._latest and key != self._shown:
            self.query_one("#history-plot", FigurePlot).show(Figure(empty_message=f"computing the {what} ..."))

    def on_history_pane_drawn(self, message: Drawn) -> None:
        """Keep a worker's figure, show it if it is still wanted."""
        if message.problem is self._kept_for:
            if len(self._kept) >= KEPT_FIGURES:
                self._kept.pop(next(iter(self._kept)))
            self._kept[message.key] = message.figure
            if message.key == self._latest:
                self._show(message.key, message.figure)

    @on(LatestWork.Done)
    def _figure_done(self, message: LatestWork.Done) -> None:
        message.work.done()  # the latest request waiting, if any, is computed next

    def _show(self, key: tuple, figure: Figure) -> None:
        plot = self.query_one("#history-plot", FigurePlot)
        if key[0] != self._shown_kind:  # another view: its own zoom and cursor
            plot.navigation.reset()
            self._shown_kind = key[0]
        self._shown = self._latest = key
        plot.show(figure)

    # -- keys ---------------------------------------------------------------------

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "next_view":
            return True if len(self.views()) > 1 else None
        if action == "mark":
            return True if self.bench is not None and self.bench.iteration > 0 else None
        return True

    def action_mark(self) -> None:
        """Mark the selected iteration (again: unmark it); the plot and tableau compare with it."""
        iteration = self.selected
        self.compare_mark = None if self.compare_mark == iteration else iteration
        self.app.notify(
            "no iteration marked"
            if self.compare_mark is None
            else f"iteration {iteration} marked: the others are compared with it",
            timeout=4,
        )
        self.show_iteration(iteration)

    def action_next_view(self) -> None:
        views = self.views()
        if views:
            self.show_view(views[(views.index(self.kind) + 1) % len(views)] if self.kind in views else views[0])

    def show_view(self, kind: str) -> None:
        self.kind = kind
        self.show_iteration(self.selected)

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        if event.data_table.id == "history-table" and event.cursor_row is not None:
            self.show_iteration(event.cursor_row)

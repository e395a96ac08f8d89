"""The Textual app: opens sessions, runs the algorithm in a thread worker,
and routes keys to the workbench screen.  Numerics never run on the UI
thread; the worker checks for a pause before every iteration and reports
through `call_from_thread`."""

from __future__ import annotations

import gc
import multiprocessing.resource_tracker
import time
from pathlib import Path

from textual import work
from textual.app import App, SystemCommand
from textual.binding import Binding
from textual.widgets import DataTable, TabbedContent
from textual.worker import get_current_worker

from engine.algorithm import load_builtin
from sessions.errors import SessionError
from sessions.store import autosave_candidate, load_session, parse_session
from sessions.sweeps import parse_sweep

from . import editing
from .files import NEW_SESSION, remember, working_copy
from .screens.dialogs import ChooseDialog, ConfirmDialog, EditDialog, HelpScreen
from .screens.main import MainScreen
from .screens.start import StartScreen
from .widgets.plots import FigurePlot
from .workbench import Workbench

REDRAW_INTERVAL = 0.25  # while running, the screen is updated at most this often (s)


class LoopcraftApp(App):
    """``LoopcraftApp(path)`` opens a session; without a path, the start screen."""

    TITLE = "loopcraft"
    BINDINGS = [
        Binding("s", "step", "step"), Binding("n", "run_n", "run N"), Binding("r", "run", "run"),
        Binding("space,escape", "pause", "pause"), Binding("z", "undo", "undo"),
        Binding("a", "choose_algorithm", "algorithm"), Binding("e,enter", "edit", "edit", show=False),
        Binding("f", "toggle_free", "free/fix", show=False), Binding("i", "import_table", "import CSV", show=False), Binding("b", "start_here", "start here", show=False),
        Binding("plus", "add", "add", show=False), Binding("minus,delete", "delete", "delete", show=False),
        Binding("c", "copy_condition", "copy condition", show=False),
        Binding("g", "toggle_per_condition", "shared/per condition", show=False),
        Binding("x", "delete_condition", "delete condition", show=False),
        Binding("v", "next_condition", "conditions", show=False),
        Binding("w", "sweep", "sweep", show=False), Binding("u", "use_best", "use best", show=False),
        Binding("ctrl+s", "save", "save"), Binding("ctrl+o", "open", "open"),
        Binding("question_mark", "help", "help"), Binding("q", "quit", "quit"),
    ]

    def __init__(self, path: str | Path | None = None):
        super().__init__()
        self.initial_path = Path(path) if path else None
        self.bench: Workbench | None = None
        self._pause = False
        self._sweep_cancel = False
        self._last_redraw = 0.0
        # Dask's worker processes, started from inside the running app, need the
        # resource tracker up before Textual takes over the terminal (docs/architecture.md)
        multiprocessing.resource_tracker.ensure_running()
        load_builtin()

    def on_mount(self) -> None:
        if self.initial_path is not None:
            self.open_path(self.initial_path)
        else:
            self.push_screen(StartScreen())

    # -- opening and saving -------------------------------------------------

    def open_path(self, path: Path) -> None:
        path = working_copy(Path(path))
        autosave = autosave_candidate(path)
        if autosave is not None:
            def answer(yes: bool) -> None:
                self._open(autosave if yes else path, keep_path=path)
            self.push_screen(ConfirmDialog(f"{autosave.name} is newer than {path.name}: recover it?"), answer)
        else:
            self._open(path)

    def _open(self, path: Path, keep_path: Path | None = None) -> None:
        try:
            if keep_path is not None and path != keep_path:
                session = parse_session(path.read_text(encoding="utf-8"), str(path), keep_path.parent)
                session.path = keep_path
            else:
                session = load_session(path)
        except SessionError as exc:
            self.notify(str(exc), title="cannot open", severity="error", timeout=10)
            if not self.screen_stack or not isinstance(self.screen, (StartScreen, MainScreen)):
                self.push_screen(StartScreen())
            return
        self.bench = Workbench(session)
        self.bench.dirty = keep_path is not None and path != keep_path
        remember(session.path)
        while len(self.screen_stack) > 1:
            self.pop_screen()
        self.push_screen(MainScreen(self.bench))

    def action_open(self) -> None:
        def chosen(text: str | None) -> None:
            if text:
                self.open_path(Path(text).expanduser())
        self.push_screen(EditDialog("open session (path)", "", _existing_file), chosen)

    def action_new(self) -> None:
        import json
        session = parse_session(json.dumps(NEW_SESSION), "new session", Path.cwd())
        self.bench = Workbench(session)
        self.push_screen(MainScreen(self.bench))

    def action_save(self) -> None:
        if self.bench is None:
            return
        if self.bench.session.path is None:
            self.action_save_as()
            return
        self._save(None)

    def action_save_as(self) -> None:
        def chosen(text: str | None) -> None:
            if text:
                self._save(Path(text).expanduser())
        self.push_screen(EditDialog("save as (path)", "", None), chosen)

    def _save(self, path: Path | None) -> None:
        try:
            target = self.bench.save(path)
        except SessionError as exc:
            self.notify(str(exc), title="not saved", severity="error", timeout=10)
            return
        self.notify(f"saved {target}")
        self._refresh()

    def action_quit(self) -> None:
        if self.bench is not None and self.bench.dirty:
            def answer(yes: bool) -> None:
                if yes:
                    self.exit(0)
            self.push_screen(ConfirmDialog("unsaved changes (an autosave is kept): quit anyway?"), answer)
        else:
            self.exit(0)

    def action_help(self) -> None:
        self.push_screen(HelpScreen())

    # -- running --------------------------------------------------------------

    def action_step(self) -> None:
        self._start(1)

    def action_run(self) -> None:
        self._start(10 ** 9)

    def action_run_n(self) -> None:
        def chosen(text: str | None) -> None:
            if text:
                self._start(int(float(text)))
        self.push_screen(EditDialog("run how many iterations?", "10", _positive_integer), chosen)

    def action_pause(self) -> None:
        self._pause = True
        self._sweep_cancel = True
        for worker in self.workers:
            if worker.group == "run":
                worker.cancel()

    def _start(self, count: int) -> None:
        if self.bench is None or any(w.group == "run" and w.is_running for w in self.workers):
            return
        self._pause = False
        self._run_worker(count)

    @work(thread=True, exclusive=True, exit_on_error=False, group="run")
    def _run_worker(self, count: int) -> None:
        gc.freeze()
        try:
            self._run_iterations(count)
        finally:
            gc.unfreeze()

    def _run_iterations(self, count: int) -> None:
        """The run's loop.  Every screen update also freezes the heap (`gc.freeze`):
        a full collection scans only what is newer, where scanning a long
        session's records held the interpreter, and so the UI, for 50-150 ms."""
        worker = get_current_worker()
        drawn = False
        for _ in range(count):
            if worker.is_cancelled or self._pause:
                break
            try:
                record = self.bench.step()
            except Exception as exc:  # an engine failure must not close the app
                self.bench.autosave()
                self.call_from_thread(self._failed, exc)
                return
            if record is None:
                self.call_from_thread(self.notify, "the algorithm has finished; z undoes, a changes it")
                break
            final = record.status.finished
            drawn = final or count == 1 or time.monotonic() - self._last_redraw >= REDRAW_INTERVAL
            if drawn:   # while a run goes the screen is updated a few times a second, not every iteration
                self._last_redraw = time.monotonic()
                self.call_from_thread(self._stepped, *self._drawings(True))
                gc.freeze()
            if final:
                break
        self.bench.autosave()
        if not drawn:
            self.call_from_thread(self._stepped, *self._drawings(True))

    def _drawings(self, redraw: bool) -> tuple:
        """In the worker: the figures and their text, drawn off the UI thread."""
        screen = self._main()
        if not redraw or screen is None:
            return (False, None, None)
        figures = screen.figures()
        canvases = screen.canvases()
        prebuilt = {name: FigurePlot.prebuild(figures[name], canvas) for name, canvas in canvases.items()
                    if name in figures}
        return (True, figures, prebuilt)

    def _stepped(self, redraw: bool, figures: dict | None = None, prebuilt: dict | None = None) -> None:
        screen = self._main()
        if screen is None:
            return
        screen.refresh_status()
        screen.refresh_run(plots=redraw, figures=figures, prebuilt=prebuilt)
        if redraw:
            screen.refresh_history()

    def _failed(self, exc: Exception) -> None:
        self.notify(f"{type(exc).__name__}: {exc}", title="iteration failed", severity="error", timeout=10)
        self._refresh()

    def action_next_condition(self) -> None:
        """Plots: every flight condition together, then each alone with its initial design."""
        screen = self._main()
        if self.bench is None or screen is None:
            return
        self.notify(self.bench.next_plotted_condition(), timeout=3)
        screen.refresh_plots()

    # -- sweeps -------------------------------------------------------------------

    def action_sweep(self) -> None:
        """Ask for a sweep (one line), then run it on Dask in a worker thread."""
        if self.bench is None or any(w.group == "sweep" and w.is_running for w in self.workers):
            return

        def check(text: str) -> str | None:
            try:
                parse_sweep(text)
            except SessionError as exc:
                return str(exc)
            return None

        def chosen(text: str | None) -> None:
            if text:
                self._sweep_cancel = False
                screen = self._main()
                if screen is not None:
                    screen.action_tab("sweep")
                    screen.refresh_sweep(f"sweep {text}: starting the cluster ...  (space cancels)")
                self._sweep_worker(text)
        self.push_screen(EditDialog("sweep: starts N [spread F] [seed S] | vary NAME=V1,V2,... | tolerance "
                                    "NAME=+-10% [samples N]; end with 'at tcp://HOST:PORT' for a cluster",
                                    "starts 16", check), chosen)

    @work(thread=True, exclusive=True, exit_on_error=False, group="sweep")
    def _sweep_worker(self, text: str) -> None:
        def progress(done: int, total: int) -> None:
            screen = self._main()
            if screen is not None:
                self.call_from_thread(screen.refresh_sweep, f"sweep {text}: {done}/{total} runs  (space cancels)")
        try:
            summary = self.bench.run_sweep(text, progress, lambda: self._sweep_cancel)
        except Exception as exc:  # a cluster that cannot be reached must not close the app
            self.call_from_thread(self.notify, f"{type(exc).__name__}: {exc}", title="sweep failed",
                                  severity="error", timeout=10)
            return
        self.call_from_thread(self._swept, summary)

    def _swept(self, summary: dict) -> None:
        self.bench.keep_sweep(summary)
        self._refresh()
        self.notify(f"sweep done: {len(summary['runs'])} runs, {len(summary['optima'])} optima")

    def action_use_best(self) -> None:
        """Adopt the latest sweep's best run as the session's start (asks when iterations would go)."""
        if self.bench is None or self.bench.latest_sweep() is None:
            return

        def adopt(yes: bool | None = True) -> None:
            if not yes:
                return
            try:
                run = self.bench.adopt_best()
            except SessionError as exc:
                self.notify(str(exc), severity="error")
                return
            self._refresh()
            self.notify(f"the start is now run {run['index']}'s design")
        if self.bench.iteration:
            self.push_screen(ConfirmDialog(f"the {self.bench.iteration} recorded iteration(s) will be dropped. "
                                           "Use the best optimum?"), adopt)
        else:
            adopt()

    def action_undo(self) -> None:
        if self.bench is not None and self.bench.undo():
            self._refresh()

    def action_choose_algorithm(self) -> None:
        from engine.algorithm import REGISTRY

        def chosen(name: str | None) -> None:
            if name and name != self.bench.algorithm_name:
                self.bench.set_algorithm(name)
                self._refresh()
        choices = [(name, reg.summary) for name, reg in sorted(REGISTRY.items()) if name != "gradient"]
        self.push_screen(ChooseDialog("algorithm", choices), chosen)

    def action_start_here(self) -> None:
        screen = self._main()
        if screen is None or screen.query_one("#tabs", TabbedContent).active != "history":
            return
        row = screen.query_one("#history-table", DataTable).cursor_row
        self.bench.start_from(row)
        self.notify(f"iteration {row} is the current one; later iterations were dropped")
        self._refresh()

    # -- editing ----------------------------------------------------------------

    def action_edit(self) -> None:
        screen = self._main()
        if screen is None or self.bench is None:
            return
        focused = self.focused
        choices = {"targets-table": ("edit which part of the target?", editing.TARGET_FIELDS, editing.target_edit),
                   "parameters": ("edit which field of the parameter?", editing.PARAMETER_FIELDS,
                                  editing.parameter_edit)}
        if isinstance(focused, DataTable) and focused.id in choices:
            row, (title, fields, make) = focused.cursor_row, choices[focused.id]

            def chosen(field: str | None) -> None:
                if field:
                    self._open_edit(make(self.bench, row, field))
            self.push_screen(ChooseDialog(title, fields), chosen)
            return
        self._open_edit(self._edit_for(screen))

    def action_add(self) -> None:
        """+: a new target (choose its measure), parameter or block, on the focused table."""
        focused = self.focused
        if self.bench is None or not isinstance(focused, DataTable):
            return
        row = focused.cursor_row
        if focused.id == "targets-table":
            from engine.problem import MEASURE_NAMES
            choices = [(m, f"default desired {editing.DEFAULT_DESIRED.get(m, 1.0):g}") for m in MEASURE_NAMES]
            self.push_screen(ChooseDialog("add a target: which measure?", choices),
                             lambda m: m and self._change(lambda: editing.add_target(self.bench, m), f"add {m}"))
        elif focused.id in ("parameters", "blocks"):
            title = ("new parameter: NAME VALUE [MIN MAX]" if focused.id == "parameters"
                     else "new block: NAME INPUT OUTPUT EXPRESSION, or matrix entry: ROW COL EXPRESSION")
            add = ((lambda text: editing.add_parameter(self.bench, text)) if focused.id == "parameters"
                   else (lambda text: editing.add_block(self.bench, row, text)))
            self.push_screen(EditDialog(title, "", editing.ADD_CHECKS[focused.id]),
                             lambda text: text and self._change(lambda: add(text), "add it"))

    def action_delete(self) -> None:
        """-/delete: remove the selected target, parameter or diagram block (asks first)."""
        focused = self.focused
        if self.bench is None or not isinstance(focused, DataTable) or focused.row_count == 0:
            return
        table, row = focused.id, focused.cursor_row
        self._change(lambda: self.notify(f"deleted {editing.delete_row(self.bench, table, row) or 'nothing'}"),
                     "delete the selected row", always_ask=True)

    def action_toggle_per_condition(self) -> None:
        """g on the parameters table: shared <-> one value per condition."""
        focused = self.focused
        if self.bench is None or not isinstance(focused, DataTable) or focused.id != "parameters":
            return
        row = focused.cursor_row
        self._change(lambda: editing.toggle_per_condition(self.bench, row), "switch shared/per condition")

    def action_copy_condition(self) -> None:
        """c on the plant table: a new flight condition copied from the selected row's."""
        focused = self.focused
        if self.bench is None or not isinstance(focused, DataTable) or focused.id != "blocks":
            return
        row = focused.cursor_row
        self.push_screen(EditDialog("copy this condition as (a new name):", "", lambda t: None if t.strip() else
                                    "a name"),
                         lambda name: name and self._change(lambda: editing.copy_condition(self.bench, row, name.strip()),
                                                            f"add condition {name}"))

    def action_delete_condition(self) -> None:
        """x on the plant table: delete the selected row's flight condition (asks first)."""
        focused = self.focused
        if self.bench is None or not isinstance(focused, DataTable) or focused.id != "blocks":
            return
        row = focused.cursor_row
        self._change(lambda: self.notify(f"deleted condition {editing.delete_condition(self.bench, row)}"),
                     "delete the selected row's condition", always_ask=True)

    def _change(self, change, what: str, always_ask: bool = False) -> None:
        """Apply a change of the problem (asking first when iterations would be dropped)."""
        def apply(yes: bool | None = True) -> None:
            if not yes:
                return
            try:
                change()
            except (SessionError, ValueError) as exc:
                self.notify(str(exc), title="not applied: nothing changed", severity="error", timeout=10)
            self._refresh()
        if self.bench.iteration or always_ask:
            dropped = (f"; the {self.bench.iteration} recorded iteration(s) will be dropped"
                       if self.bench.iteration else "")
            self.push_screen(ConfirmDialog(f"{what}{dropped}?"), apply)
        else:
            apply()

    def _open_edit(self, edit) -> None:
        if edit is None:
            return

        def apply(text: str) -> None:
            try:
                edit.apply(text)
            except (SessionError, ValueError) as exc:
                self.notify(str(exc), title="not applied: the old value is kept", severity="error", timeout=10)
            self._refresh()

        def done(text: str | None) -> None:
            if text is None:
                return
            if self.bench.iteration == 0:
                apply(text)
                return
            question = (f"this edit changes the problem: the {self.bench.iteration} recorded iteration(s) will be "
                        "dropped (save first to keep them). Apply?")
            self.push_screen(ConfirmDialog(question), lambda yes: apply(text) if yes else None)
        self.push_screen(EditDialog(edit.title, edit.text, edit.check), done)

    def _edit_for(self, screen: MainScreen):
        focused = self.focused
        if not isinstance(focused, DataTable):
            return None
        row = focused.cursor_row
        if focused.id == "blocks":
            return editing.block_edit(self.bench, row)
        if focused.id == "objective-table":
            rows = editing.objective_rows(self.bench)
            return rows[row][2]() if 0 <= row < len(rows) and rows[row][2] is not None else None
        return None

    def action_import_table(self) -> None:
        """Plant tab: make the selected block a table read from a CSV file (with a preview)."""
        focused = self.focused
        if not (isinstance(focused, DataTable) and focused.id == "blocks" and self.bench is not None):
            return
        row = focused.cursor_row
        folder = self.bench.session.path.parent if self.bench.session.path else Path.cwd()

        def chosen(text: str | None) -> None:
            if not text:
                return
            path = Path(text).expanduser()
            path = path if path.is_absolute() else folder / path
            try:
                edit = editing.table_import(self.bench, row, path)
            except (OSError, ValueError) as exc:
                self.notify(str(exc), title="cannot read the table", severity="error")
                return
            if edit is None:
                self.notify("select a block of a block diagram first", severity="warning")
            self._open_edit(edit)
        self.push_screen(EditDialog("CSV file (relative to the session's folder)", "",
                                    lambda t: None if (folder / Path(t).expanduser()).is_file()
                                    or Path(t).expanduser().is_file() else "no such file"), chosen)

    def action_toggle_free(self) -> None:
        focused = self.focused
        if isinstance(focused, DataTable) and focused.id == "parameters" and self.bench is not None:
            try:
                editing.toggle_free(self.bench, focused.cursor_row)
            except SessionError as exc:
                self.notify(str(exc), severity="error")
            self._refresh()

    # -- helpers ----------------------------------------------------------------

    def _main(self) -> MainScreen | None:
        return self.screen if isinstance(self.screen, MainScreen) else next(
            (s for s in reversed(self.screen_stack) if isinstance(s, MainScreen)), None)

    def _refresh(self) -> None:
        screen = self._main()
        if screen is not None:
            screen.refresh_all()

    def get_system_commands(self, screen):
        yield from super().get_system_commands(screen)
        for title, help_text, action in [
            ("Step", "one iteration (s)", self.action_step), ("Run N", "N iterations (n)", self.action_run_n),
            ("Run", "until the algorithm stops (r)", self.action_run), ("Pause", "stop a run", self.action_pause),
            ("Undo", "drop the last iteration (z)", self.action_undo),
            ("Algorithm", "choose the algorithm (a)", self.action_choose_algorithm),
            ("Save", "save the session (ctrl+s)", self.action_save), ("Save as", "save under a new name",
                                                                     self.action_save_as),
            ("Open", "open a session (ctrl+o)", self.action_open), ("New session", "a new session", self.action_new),
            ("Conditions", "plots: every flight condition or one (v)", self.action_next_condition),
            ("Sweep", "many runs on Dask (w)", self.action_sweep),
            ("Use best", "the latest sweep's best design as the start (u)", self.action_use_best),
            ("Keys", "every key (?)", self.action_help)]:
            yield SystemCommand(title, help_text, action)


def _existing_file(text: str) -> str | None:
    return None if Path(text).expanduser().is_file() else "no such file"


def _positive_integer(text: str) -> str | None:
    try:
        return None if int(float(text)) >= 1 else "at least 1"
    except ValueError:
        return "a whole number"

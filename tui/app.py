"""The Textual app: opens and saves sessions, runs the algorithm (`RunLoop`),
sweeps (`Sweeps`) and exports (`Exports`), each a part composed into it, and
says which keys can act now.

Keys are written once, as bindings with a description and a tooltip: the
footer, the help screen and the command palette are made from them.  A
key that would change the session is disabled (dimmed) while a run or a
sweep goes (`busy`), through `check_action`; the tables do the same for
their own keys."""

from __future__ import annotations

import json
import multiprocessing.resource_tracker
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from textual import on
from textual.actions import parse as parse_action
from textual.app import App, SystemCommand
from textual.binding import Binding

from engine.errors import EngineError
from sessions.build import OutsideTable
from sessions.errors import SessionError, bounded_message
from sessions.format.save_file import OverwriteRefused, describe
from sessions.store import (
    autosave_candidate,
    flush_autosaves,
    parse_session,
    set_aside_autosave,
)
from sessions.target_use import unusable_targets
from tui.actions.exports import Exports
from tui.actions.run_loop import RunLoop
from tui.actions.sweeps import Sweeps
from tui.config import Config
from tui.drawing.graphics import Graphics
from tui.files import file_problem, remember, untitled_path, working_copy
from tui.keys import identified
from tui.screens.dialogs import ChooseDialog, ConfirmDialog, EditDialog, HelpScreen
from tui.screens.edit_flow import EditFlow
from tui.screens.main import MainScreen
from tui.screens.new_flow import NewSessionFlow, copy_tables
from tui.screens.start import StartScreen
from tui.state.bench.persistence import reopen
from tui.state.workbench import Workbench
from tui.terminal_watch import HANGUP_EXIT, watch_terminal

FOOTER_DIM_DELAY = 0.15  # s: work still going then has its footer's keys dimmed


@dataclass(frozen=True)
class KeyAction:
    """One row of the app's action table: its binding, whether it changes or replaces the
    session (disabled while a run or a sweep goes) and whether it needs an open session
    (hidden on the start screen)."""

    binding: Binding
    changes: bool = False
    needs_session: bool = False


# the app's keys, each once: the bindings, the footer, the help, the palette and
# which keys can act now (`check_action`) are all read from this table
ACTIONS = (
    KeyAction(Binding("s", "step", "step", tooltip="one iteration"), changes=True, needs_session=True),
    KeyAction(Binding("n", "run_n", "run N", tooltip="N iterations (asks N)"), changes=True, needs_session=True),
    KeyAction(Binding("r", "run", "run", tooltip="until the algorithm stops"), changes=True, needs_session=True),
    KeyAction(
        Binding("space,escape", "pause", "pause", tooltip="stop a run or a sweep (within one iteration)"),
        needs_session=True,
    ),
    KeyAction(Binding("z", "undo", "undo", tooltip="drop the last iteration"), changes=True, needs_session=True),
    KeyAction(
        Binding("Z", "redo", "redo", show=False, tooltip="bring back the last iteration dropped"),
        changes=True,
        needs_session=True,
    ),
    KeyAction(
        Binding("ctrl+z", "undo_edit", "undo edit", show=False, tooltip="undo the last edit of the problem"),
        changes=True,
        needs_session=True,
    ),
    KeyAction(
        Binding("ctrl+y", "redo_edit", "redo edit", show=False, tooltip="redo the last edit undone"),
        changes=True,
        needs_session=True,
    ),
    KeyAction(
        Binding("a", "choose_algorithm", "algorithm", tooltip="choose the algorithm (the records are dropped)"),
        changes=True,
        needs_session=True,
    ),
    KeyAction(
        Binding("d", "adopt_design", "adopt design", show=False, tooltip="the current design becomes the start"),
        changes=True,
        needs_session=True,
    ),
    KeyAction(
        Binding(
            "v",
            "next_condition",
            "conditions",
            show=False,
            tooltip="plots: every flight condition, or one with its initial design",
        ),
        needs_session=True,
    ),
    KeyAction(
        Binding(
            "b",
            "next_break",
            "break",
            show=False,
            tooltip="Bode, Nyquist, Nichols: the loop at the next break (the others closed), then the primary again",
        ),
        needs_session=True,
    ),
    KeyAction(
        Binding("w", "sweep", "sweep", show=False, tooltip="many runs on Dask: starts, vary, tolerance"),
        changes=True,
        needs_session=True,
    ),
    KeyAction(
        Binding("u", "use_best", "use best", show=False, tooltip="best design, or worst sample, as the start"),
        changes=True,
        needs_session=True,
    ),
    KeyAction(
        Binding("ctrl+s", "save", "save", show=False, tooltip="save the session (a new one: asks for its name)"),
        needs_session=True,
    ),
    KeyAction(
        Binding("f12", "save_as", "save as", show=False, tooltip="save the session under another name (asks for it)"),
        needs_session=True,
    ),
    KeyAction(Binding("ctrl+o", "open", "open", tooltip="open a session file"), changes=True),
    KeyAction(Binding("ctrl+n", "new", "new", show=False, tooltip="a new session from a template"), changes=True),
    KeyAction(
        Binding(
            "ctrl+e",
            "export",
            "export",
            show=False,
            tooltip="the current design as a python-control or MATLAB script, JSON or CSV, beside the session",
        ),
        needs_session=True,
    ),
    KeyAction(
        Binding("S", "save_screenshot", "screenshot", show=False, tooltip="an SVG screenshot beside the session"),
        needs_session=True,
    ),
    KeyAction(Binding("question_mark", "help", "help", show=False, tooltip="every key")),
    KeyAction(Binding("q", "quit", "quit", tooltip="quit (asks when there are unsaved changes)")),
)
CHANGES = frozenset(a.binding.action for a in ACTIONS if a.changes)
SESSION_ACTIONS = frozenset(a.binding.action for a in ACTIONS if a.needs_session)


class LoopcraftApp(App):
    """``LoopcraftApp(path)`` opens a session; without a path, the start screen.  Its state
    is composed: the run loop (`runs`), the sweeps (`sweeps`), the exports (`exports`) and
    the edit dialogs (`edit_flow`), each with its own attributes."""

    TITLE = "loopcraft"
    BINDINGS = identified("app", [a.binding for a in ACTIONS])

    def __init__(self, path: str | Path | None = None, graphics: Graphics | None = None):
        super().__init__()
        self.initial_path = Path(path) if path else None
        self.graphics = graphics  # the terminal's image protocol, asked before the app ran (None: text plots)
        self.bench: Workbench | None = None
        self.edit_flow = EditFlow(self)
        self.runs = RunLoop(self)
        self.sweeps = Sweeps(self)
        self.exports = Exports(self)
        self._refused_at = 0.0
        self._last_action: object = None  # the latest key's action: another one ends a burst of edits
        self.config = Config()
        # Dask's worker processes, started from inside the running app, need the
        # resource tracker up before Textual takes over the terminal (docs/architecture.md)
        multiprocessing.resource_tracker.ensure_running()

    def notify(
        self,
        message: str,
        *,
        title: str = "",
        severity="information",
        timeout: float | None = None,
        markup: bool = False,
    ) -> None:
        """A notification; plain text by default (an error message may hold brackets: a[3,2], [/ R]);
        an echoed input in it is cut (`sessions.errors.bounded_message`)."""
        super().notify(bounded_message(message), title=title, severity=severity, timeout=timeout, markup=markup)

    @property
    def busy(self) -> bool:
        """A run or a sweep is going: nothing may change the session."""
        return self.runs.running or self.sweeps.sweeping

    def busy_changed(self) -> None:
        """Enable or disable the keys that change the session (at once: `check_action`);
        the footer dims them when the work lasts `FOOTER_DIM_DELAY` (a step that ends
        before would make it flicker, and rebuild it twice for nothing)."""
        if self.busy:
            self.set_timer(FOOTER_DIM_DELAY, self._dim_if_busy)
        else:
            self.screen.refresh_bindings()
        main = self.main_screen()
        if main is not None:
            main.refresh_status()

    def _dim_if_busy(self) -> None:
        if self.busy:
            self.screen.refresh_bindings()

    # -- the actions the composed parts carry out ------------------------------

    def action_step(self) -> None:
        self.runs.step()

    def action_run(self) -> None:
        self.runs.run()

    def action_run_n(self) -> None:
        self.runs.run_n()

    def action_pause(self) -> None:
        self.runs.pause()
        self.sweeps.cancel()

    def action_sweep(self) -> None:
        self.sweeps.ask()

    def action_use_best(self) -> None:
        self.sweeps.use_best()

    def action_export(self) -> None:
        self.exports.export()

    def action_save_screenshot(self) -> None:
        self.exports.screenshot()

    # -- what the workers post back ---------------------------------------------

    @on(RunLoop.Stepped)
    def _stepped(self, message: RunLoop.Stepped) -> None:
        self.runs.stepped(message)

    @on(RunLoop.Drawn)
    def _drawn(self, message: RunLoop.Drawn) -> None:
        self.runs.drawn(message)

    @on(RunLoop.Ended)
    def _run_ended(self, message: RunLoop.Ended) -> None:
        self.runs.ended(message)

    @on(RunLoop.Failed)
    def _run_failed(self, message: RunLoop.Failed) -> None:
        self.runs.failed(message)

    @on(Sweeps.Progress)
    def _sweep_progress(self, message: Sweeps.Progress) -> None:
        self.sweeps.progressed(message)

    @on(Sweeps.Done)
    def _sweep_done(self, message: Sweeps.Done) -> None:
        self.sweeps.done(message)

    @on(Sweeps.Failed)
    def _sweep_failed(self, message: Sweeps.Failed) -> None:
        self.sweeps.failed(message)

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action in CHANGES and self.busy:
            return None
        if action in SESSION_ACTIONS and self.bench is None:
            return False  # no session (the start screen): not shown at all
        if action == "pause" and not self.busy:
            return None
        return None if self.bench is not None and not self._can(action) else True

    def _can(self, action: str) -> bool:
        """Whether the key has something to act on (`disabled_reason` says why not)."""
        return self.disabled_reason(action) is None

    async def run_action(self, action, default_namespace=None, namespaces=None) -> bool:
        """Run an action; a key that cannot act now says why (a run or a sweep goes, or the
        target's `disabled_reason`) in a notice and on a line under the status, until the next key.
        Any other action than the previous one ends a burst of edits (`EditHistory.end_burst`):
        a key repeated is one undo step, a key between splits it."""
        if action != self._last_action and self.bench is not None:
            self.bench.edits.end_burst()
        self._last_action = action
        main = self.main_screen()
        if main is not None:  # what a key refused before said goes (a shaping key's own refusal comes after)
            main.say_refused("")
        handled = await super().run_action(action, default_namespace, namespaces)
        if not handled:
            destination, name, params = action if isinstance(action, tuple) else parse_action(action)
            target = (namespaces or {}).get(destination) or {"app": self, "screen": self.screen}.get(destination)
            target = target or (self if default_namespace is None else default_namespace)
            if target.check_action(name, params) is None and name != "pause":
                reason = self.key_reason(name, target)
                refused = f"{name.replace('_', ' ')}: {reason}"
                if reason and main is not None:  # on the status line until the next key
                    main.say_refused(refused)
                now = time.monotonic()
                if reason and now - self._refused_at > 1.0:
                    self._refused_at = now
                    self.notify(refused, timeout=3)
        return handled

    def key_reason(self, action: str, target: object | None = None) -> str | None:
        """Why a key's action cannot act now (a refused key's notice, the footer's tooltip): a
        run or a sweep goes, or ``target``'s `disabled_reason` (none given: the app's or the
        screen's, whichever names it)."""
        if self.busy:
            return self._busy_reason()
        name = parse_action(action)[1]
        for asked in (self, self.screen) if target is None else (target,):
            reason = getattr(asked, "disabled_reason", lambda _: None)(name)
            if reason:
                return reason
        return None

    def _busy_reason(self) -> str:
        return f"not while {'a sweep' if self.sweeps.sweeping else 'a run'} goes (space pauses it)"

    def disabled_reason(self, action: str) -> str | None:
        """Why an app key cannot act now (None: it can, or it says nothing)."""
        bench = self.bench
        if bench is None:
            return None
        can, reason = {  # only the asked key's test runs: check_action asks for every key of every refresh
            "undo": (lambda: bench.iteration > 0, "no iteration to drop"),
            "redo": (lambda: bench.can_redo, "no iteration was dropped"),
            "undo_edit": (lambda: bool(bench.edits.undo_stack), "no edit to undo"),
            "redo_edit": (lambda: bool(bench.edits.redo_stack), "no edit to redo"),
            "adopt_design": (lambda: bench.iteration > 0, "no iteration yet: the start is the current design"),
        }.get(action, (lambda: True, None))
        if action == "use_best":  # why depends on the sweep: none yet, or none of its runs finished
            return bench.sweeps.refusal()
        if action == "next_break":  # a session whose conditions name one break each
            return bench.break_refusal()
        return None if can() else reason

    def on_mount(self) -> None:
        watch_terminal(self, self._terminal_lost)
        self.apply_config()
        if self.initial_path is not None:
            self.open_path(self.initial_path)
        else:
            self.push_screen(StartScreen())

    def on_unmount(self) -> None:
        flush_autosaves()  # the autosaves still being written in the background: nothing is lost

    def apply_config(self) -> None:
        """The user's theme and keys (`tui.config`); a config that does not read is
        reported and the defaults are kept."""
        from tui.config import ConfigError, load_config, unknown_binding_ids
        from tui.keys import binding_table

        try:
            self.config = load_config(themes=set(self.available_themes))
        except ConfigError as exc:
            self.notify(f"{exc} (the defaults are used)", title="config", severity="warning", timeout=12)
            return
        self.theme = self.config.theme
        if self.config.plots == "image" and self.graphics is None:
            self.notify(
                'plots = "image", but this terminal shows no images (sixel or kitty graphics; in tmux: '
                "set -g allow-passthrough on): the plots are text",
                title="config",
                timeout=8,
            )
        unknown = unknown_binding_ids(self.config, {row[0] for row in binding_table()})
        if unknown:
            self.notify(
                f"[keys]: no binding {', '.join(unknown)} (loopcraft config lists them)",
                title="config",
                severity="warning",
                timeout=12,
            )
        self.set_keymap(self.config.keys)

    # -- opening and saving -------------------------------------------------

    def open_path(self, path: Path) -> None:
        """Open a session file (a bundled example's working copy), offering a newer autosave;
        a path that cannot be opened is a message (a name over 255 bytes, a folder, ...)."""
        problem = file_problem(Path(path))
        if problem is not None:
            self.notify(f"{path}: {problem}", title="cannot open", severity="error", timeout=10)
            return
        try:
            path = working_copy(Path(path))
        except OSError as exc:
            self.notify(f"{path}: {describe(exc)}", title="cannot open", severity="error", timeout=10)
            return
        autosave = autosave_candidate(path)
        if autosave is not None:

            def answer(yes: bool) -> None:
                if not yes:
                    try:
                        kept = set_aside_autosave(path)
                    except SessionError as exc:
                        self.notify(str(exc), severity="warning", timeout=8)
                    else:
                        self.notify(f"the autosave is kept as {kept.name} (not offered again)", timeout=6)
                self._open(autosave if yes else path, keep_path=path)

            self.push_screen(ConfirmDialog(f"{autosave.name} is newer than {path.name}: recover it?"), answer)
        else:
            self._open(path)

    def _open(self, path: Path, keep_path: Path | None = None, allow_outside_tables: bool = False) -> None:
        recovering = keep_path is not None and path != keep_path
        try:
            session = reopen(path, keep_path, allow_outside_tables)
        except OutsideTable as exc:
            question = f"this session reads a table outside its folder: {exc.name}. Read it?"
            self.push_screen(
                ConfirmDialog(question), lambda yes: yes and self._open(path, keep_path, allow_outside_tables=True)
            )
            return
        except (SessionError, OSError) as exc:
            self.notify(str(exc), title="cannot open", severity="error", timeout=10)
            if not self.screen_stack or not isinstance(self.screen, (StartScreen, MainScreen)):
                self.push_screen(StartScreen())
            return
        self._show(Workbench(session), dirty=recovering)
        remember(session.path)

    def _show(self, bench: Workbench, dirty: bool = False) -> None:
        self.bench = bench
        bench.dirty = dirty
        while len(self.screen_stack) > 1:
            self.pop_screen()
        self.push_screen(MainScreen(bench))
        self.refresh_bindings()

    def action_open(self) -> None:
        self._ask_to_drop(
            lambda: self.push_screen(
                EditDialog("open session (path)", "", _existing_file),
                lambda text: text and self.open_path(Path(text).expanduser()),
            ),
            "open another session",
        )

    def action_new(self) -> None:
        """A new session from a template (asks before dropping unsaved work)."""
        self._ask_to_drop(lambda: NewSessionFlow(self, self._create).start(), "start a new session")

    def _create(self, data: dict, tables: list[Path]) -> None:
        """Open new session data as an untitled session (its tables copied beside it)."""
        path = untitled_path()
        try:
            copy_tables(tables, path.parent)
            session = parse_session(json.dumps(data), str(path), path.parent)
        except (SessionError, OSError) as exc:  # never closes the app: the current session is kept
            self.notify(str(exc), title="no new session", severity="error", timeout=10)
            return
        session.path = path
        self._show(Workbench(session, untitled=True), dirty=True)
        self.notify(f"a new session, kept in {path} until saved: ctrl+s asks for its name", timeout=6)

    def _ask_to_drop(self, then, what: str = "close this session") -> None:
        """Go on when nothing unsaved would be dropped, else autosave and ask first."""
        if self.bench is not None and self.bench.dirty:
            where = self.bench.file.autosave()
            self.push_screen(ConfirmDialog(f"unsaved changes ({where}): {what} anyway?"), lambda yes: yes and then())
        else:
            then()

    def action_save(self) -> None:
        """Save in place; a new session (untitled) asks for its name first."""
        if self.bench is None:
            return
        if self.bench.file.needs_name:
            self.action_save_as()
            return
        self._save(None)

    def action_save_as(self) -> None:
        """Ask for the session's new name (a path; the current one to edit), then save there."""
        if self.bench is None:
            return
        path = self.bench.session.path
        self.push_screen(
            EditDialog("save as (a path ending in .json)", str(path) if path else "", _new_session_path),
            lambda text: text and self._save(Path(text).expanduser()),
        )

    def _save(self, path: Path | None, force: bool = False) -> None:
        try:
            target = self.bench.file.save(path, force=force)
        except OverwriteRefused as exc:
            self.push_screen(ConfirmDialog(f"{exc}. Overwrite it?"), lambda yes: yes and self._save(path, True))
            return
        except SessionError as exc:
            self.notify(str(exc), title="not saved (the session is kept in memory)", severity="error", timeout=10)
            return
        remember(target)  # a new session saved appears in the start screen's recent list
        self.notify(f"saved {target}")
        self.refresh_workbench()

    def _terminal_lost(self) -> None:
        """The terminal hung up: no one can be asked, so a run stops, the unsaved
        changes go to the autosave (offered back on the next open), and the app ends."""
        self.runs.pause()
        if self.bench is not None:
            self.bench.file.autosave()
        self.exit(HANGUP_EXIT)

    def action_quit(self) -> None:
        self.runs.pause()
        self._ask_to_drop(lambda: self.exit(0), "quit")

    def action_help(self) -> None:
        from tui.stderr_log import log_path_text

        note = f"Dask's and the workers' logs and warnings go to {log_path_text()} while the app runs"
        self.push_screen(HelpScreen(key_help(), note))

    # -- the session ----------------------------------------------------------

    def action_undo(self) -> None:
        self._move_iterations(Workbench.undo, "undo")

    def action_redo(self) -> None:
        self._move_iterations(Workbench.redo, "redo")

    def _move_iterations(self, move, what: str) -> None:
        """Undo or redo an iteration; a session that cannot step (an algorithm not installed,
        or none named) says so instead of closing the app."""
        try:
            moved = self.bench is not None and move(self.bench)
        except (SessionError, EngineError) as exc:
            self.notify(str(exc), title=f"cannot {what}", severity="error", timeout=10)
            return
        if moved:
            self.refresh_workbench()

    def action_undo_edit(self) -> None:
        self._edit_step(self.bench.edits.undo, "nothing to undo")

    def action_redo_edit(self) -> None:
        self._edit_step(self.bench.edits.redo, "nothing to redo")

    def _edit_step(self, move, nothing: str) -> None:
        if move(self.bench.book) is None:
            self.notify(nothing, timeout=3)
            return
        self.bench.file.autosave(throttled=True, wait=False)  # written by the autosave thread, as an edit's
        self.notify(self.bench.edits.last, timeout=4)
        self.refresh_workbench()

    def action_adopt_design(self) -> None:
        """The current iteration's design becomes the start (asks when iterations would go)."""
        iteration = self.bench.iteration
        self.edit_flow.change(
            self.bench.book.adopt_current,
            f"make iteration {iteration}'s design the start",
            keeps_design=False,
            done=lambda _: self.notify(f"iteration {iteration}'s design is the start (ctrl+z undoes)"),
        )

    def action_choose_algorithm(self) -> None:
        from engine.stepping.registry import lookup, registrations

        measures = [t.measure for t in self.bench.session.model.problem.targets]

        def chosen(name: str | None) -> None:
            if name and name != self.bench.algorithm_name:
                unusable = unusable_targets(measures, name)
                self.edit_flow.change(
                    lambda: self.bench.set_algorithm(name),
                    f"switch to {name}",
                    done=lambda _: (
                        unusable
                        and self.notify(
                            "\n".join(unusable), title=f"{name} and the targets", severity="warning", timeout=12
                        )
                    ),
                )

        def summary(name: str, text: str) -> str:
            count = len(unusable_targets(measures, name)) if lookup(name).targets.reads else 0
            return f"{text} [{count} of the targets judged only]" if count else text

        choices = [(name, summary(name, registration.summary)) for name, registration in registrations().items()]
        if self.bench.algorithm_name not in dict(choices):  # a plug-in not installed, or no name at all
            choices.append((self.bench.algorithm_name, "(not installed: cannot step; choose another)"))
        self.push_screen(ChooseDialog("algorithm", choices), chosen)

    def action_next_condition(self) -> None:
        """Plots: every flight condition together, then each alone with its initial design."""
        self._plots_shown(Workbench.next_plotted_condition)

    def action_next_break(self) -> None:
        """Bode, Nyquist and Nichols drawn at the next loop break (view state, never saved)."""
        self._plots_shown(Workbench.next_plotted_break)

    def _plots_shown(self, change: Callable[[Workbench], str]) -> None:
        """A change of what the plots show (view state), said in a notice, the plots drawn again."""
        screen = self.main_screen()
        if self.bench is None or screen is None:
            return
        self.notify(change(self.bench), timeout=3)
        screen.refresh_plots()

    # -- helpers ----------------------------------------------------------------

    def main_screen(self) -> MainScreen | None:
        """The workbench screen, under any dialog (None: the start screen alone)."""
        return (
            self.screen
            if isinstance(self.screen, MainScreen)
            else next((s for s in reversed(self.screen_stack) if isinstance(s, MainScreen)), None)
        )

    def refresh_workbench(self, plots: bool = True) -> None:
        """Redraw the workbench screen from the session (after any change); ``plots``
        False keeps the plots (a run's worker drew them)."""
        screen = self.main_screen()
        if screen is None:
            return
        try:
            screen.refresh_all(plots)
        except Exception as exc:  # noqa: BLE001 - a view that cannot be drawn must not close the app
            self.notify(
                f"{type(exc).__name__}: {exc}",
                title="the view could not be drawn (the session is kept)",
                severity="error",
                timeout=10,
            )

    def get_system_commands(self, screen):
        ours = {"Screenshot", "Keys"}  # Textual's own commands this app gives with its keys
        yield from (c for c in super().get_system_commands(screen) if c.title not in ours)
        for binding in self.BINDINGS:  # only what can act now
            if binding.action not in ("help", "quit") and self.check_action(binding.action, ()):
                yield SystemCommand(
                    binding.description.capitalize(),
                    f"{binding.tooltip} ({binding.key})",
                    lambda action=binding.action: self.run_action(action),
                )
        yield SystemCommand("New session", "a new session (asks before dropping unsaved work)", self.action_new)
        yield SystemCommand("Keys", "every key (?)", self.action_help)


def key_help() -> list[tuple[str, list[tuple[str, str]]]]:
    """Every key with what it does, by where it acts, from the bindings themselves."""
    from tui.widgets.tables import HistoryTable, ParametersTable, PlantTable, SettingsTable, TargetsTable

    def rows(bindings) -> list[tuple[str, str]]:
        return [(b.key.replace("question_mark", "?").replace(",", " / "), b.tooltip or b.description) for b in bindings]

    groups = [("anywhere", rows(LoopcraftApp.BINDINGS)), ("workbench", rows(MainScreen.BINDINGS))]
    from tui.screens.history_pane import HistoryPane
    from tui.widgets.plots import FigurePlot

    for name, bindings in (
        ("plant table", PlantTable.BINDINGS),
        ("parameters", ParametersTable.BINDINGS),
        ("targets", TargetsTable.BINDINGS),
        ("settings", SettingsTable.BINDINGS),
        ("history", HistoryTable.BINDINGS + HistoryPane.BINDINGS),
        ("a plot (focused)", FigurePlot.BINDINGS),
    ):
        groups.append((name, rows(bindings)))
    return groups


def _new_session_path(text: str) -> str | None:
    """Why a typed path cannot take the session (None: it can; an existing file is asked about)."""
    path = Path(text.strip()).expanduser()
    if not text.strip() or path.suffix != ".json":
        return "a path ending in .json"
    if not path.parent.is_dir():
        return f"no folder {path.parent}"
    return None


def _existing_file(text: str) -> str | None:
    return file_problem(Path(text).expanduser())

"""The run loop: a thread worker computes, the UI thread commits.

`s`, `n` and `r` take the bound stepper and the current state from the
workbench on the UI thread, then a thread worker steps: each iteration it
computes the next (State, StepRecord) from its own state and view and posts
a `Stepped` message (marked to be shown a few times a second, and always the
last).  The UI thread alone appends the record (`Workbench.commit`; its JSON made
by the worker),
autosaves and refreshes the tableau.  After a shown iteration, and once more
after the run, the worker draws the plots on screen from its own view (sizes
taken when the run began) and posts them (`Drawn`): the tableau never waits
for a plot.  After posting what the screen shows, the worker waits (at most
`PAINT_WAIT`) until the UI thread has painted it: a worker stepping on would
hold the GIL half the time and double every paint (the 50 ms timer waited
up to 180 ms).  `RunEnded` or `RunFailed` follows the last `Stepped` (messages
keep their order), and only then are the keys that change the session
enabled again, so an undo can never meet a record still on its way; plots
drawn for a view that is no longer current are dropped.
"""

from __future__ import annotations

import gc
import threading
import time
from dataclasses import dataclass

from textual import work
from textual.message import Message

from engine.stepping.protocol import State, Stepper, StepRecord
from sessions.errors import SessionError
from tui.figures.catalog import figure_key, figures
from tui.figures.closed_loop import pole_text
from tui.state.views import View
from tui.state.workbench import stored_json
from tui.widgets.plots import FigurePlot

REDRAW_INTERVAL = 0.25  # while running, the plots are redrawn at most this often (s)
FOOTER_DIM_DELAY = 0.15  # s: a run still going then has its footer's keys dimmed
PAINT_WAIT = 0.3  # s: after posting what the screen shows, the worker waits at most this for its paint


class Stepped(Message):
    """One iteration computed by the worker (``show``: refresh the tableau for it;
    ``stored``: its record's and state's JSON, made in the worker)."""

    def __init__(
        self,
        state: State,
        record: StepRecord,
        show: bool,
        stored: tuple[dict, dict],
        poles: tuple[tuple, str, View] | None = None,
    ):
        super().__init__()
        self.state, self.record, self.show, self.stored = state, record, show, stored
        self.poles = poles  # (figure_key, the pole lines under the tableau, the view), made in the worker when shown


class Drawn(Message):
    """The plots on screen drawn by the worker for the view of ``key`` (`figure_key`)."""

    def __init__(self, key: tuple, drawn: dict, prebuilt: dict):
        super().__init__()
        self.key, self.drawn, self.prebuilt = key, drawn, prebuilt


class RunEnded(Message):
    """The worker stopped: finished, paused or the count reached (``note`` says which when it matters)."""

    def __init__(self, note: str | None = None):
        super().__init__()
        self.note = note


class RunFailed(Message):
    """An iteration raised: the run stops, the records so far are kept."""

    def __init__(self, error: str):
        super().__init__()
        self.error = error


@dataclass
class RunRequest:
    """What the worker steps: the bound stepper, the state to step from, the view, how far."""

    stepper: Stepper
    state: State
    view: View
    count: int
    canvases: dict
    settings: dict | None  # the snapshot the records are kept with (`Workbench.settings`)


class RunLoop:
    """The app's run actions and the handlers of the worker's messages (a mixin of the app)."""

    running = False

    def _run_setup(self) -> None:
        self._pause = threading.Event()
        self._painted = threading.Event()  # set by the UI thread once it has painted what was posted

    def action_step(self) -> None:
        self._start(1)

    def action_run(self) -> None:
        self._start(10**9)

    def action_run_n(self) -> None:
        from tui.screens.dialogs import EditDialog

        def chosen(text: str | None) -> None:
            if text:
                self._start(int(float(text)))

        self.push_screen(EditDialog("run how many iterations?", "10", _positive_integer), chosen)

    def action_pause(self) -> None:
        self._pause.set()
        self._sweep_cancel = True

    def _start(self, count: int) -> None:
        if self.bench is None or self.busy:
            return
        try:
            stepper, state = self.bench.begin_run()
        except SessionError as exc:
            self.notify(str(exc), title="cannot run", severity="error", timeout=10)
            return
        if state.status.finished:
            self.notify("the algorithm has finished; z undoes, a changes it")
            return
        screen = self._main()
        request = RunRequest(
            stepper, state, self.bench.view(), count, screen.canvases() if screen else {}, self.bench.settings
        )
        self._pause.clear()
        self._painted.clear()
        self._set_running(True)
        self.call_after_refresh(self._painted.set)
        self._run_worker(request)

    def _set_running(self, running: bool) -> None:
        """Enable or disable the keys that change the session (at once: `check_action`);
        the footer dims them when a run lasts `FOOTER_DIM_DELAY` (a step that ends
        before would make it flicker, and rebuild it twice for nothing)."""
        self.running = running
        if running:
            self.set_timer(FOOTER_DIM_DELAY, self._dim_if_running)
        else:
            self.screen.refresh_bindings()
        main = self._main()
        if main is not None:
            main.refresh_status()

    def _dim_if_running(self) -> None:
        if self.running:
            self.screen.refresh_bindings()

    @work(thread=True, exclusive=True, exit_on_error=False, group="run")
    def _run_worker(self, request: RunRequest) -> None:
        gc.freeze()  # a full collection then scans only what is new, not a long session's records
        try:
            note, view, drawn = self._steps(request)
        except Exception as exc:  # noqa: BLE001 - an engine failure ends the run, never the app
            self.post_message(RunFailed(f"{type(exc).__name__}: {exc}"))
            return
        finally:
            gc.unfreeze()
        self._painted.clear()
        self.post_message(RunEnded(note))
        if view is not None and not drawn:
            self._painted.wait(PAINT_WAIT)  # the keys come back and are painted first
            self._post_drawings(view, request.canvases)

    def _steps(self, request: RunRequest) -> tuple[str | None, View | None, bool]:
        """In the worker: step, post every record, draw now and then; why it stopped,
        the last view and whether its plots were drawn."""
        state, view, last, drawn = request.state, request.view, 0.0, True
        self._painted.wait(PAINT_WAIT)  # the screen as the run starts is painted first
        for n in range(request.count):
            if self._pause.is_set():
                return "paused", view, drawn
            state, record = request.stepper.step(state)
            view = view.extended(record)
            final = record.status.finished or n == request.count - 1
            show = final or time.monotonic() - last >= REDRAW_INTERVAL
            self._painted.clear()
            poles = (figure_key(view), pole_text(view), view) if show else None
            self.post_message(Stepped(state, record, show, stored_json(state, record, request.settings), poles))
            drawn = False
            if show and not final:  # the last view is drawn after RunEnded: the keys need not wait
                self._painted.wait(PAINT_WAIT)  # the UI paints the tableau without the worker taking the GIL
                last = time.monotonic()
                self._painted.clear()
                self._post_drawings(view, request.canvases)
                self._painted.wait(PAINT_WAIT)  # ... and the plots
                drawn = True
            if record.status.finished:
                break
        return None, view, drawn

    def _post_drawings(self, view: View, canvases: dict) -> None:
        self.post_message(Drawn(figure_key(view), *drawings(view, canvases)))

    def on_stepped(self, message: Stepped) -> None:
        """UI thread: keep the record, then show it in the tableau when asked (and
        tell the worker once it is painted)."""
        try:
            self._show_stepped(message)
        finally:
            if message.show:
                self.call_after_refresh(self._painted.set)

    def _show_stepped(self, message: Stepped) -> None:
        try:
            self.bench.commit(message.state, message.record, message.stored)
        except SessionError as exc:  # cannot happen while changes are disabled; said, never silent
            self.notify(str(exc), title="record not kept", severity="error", timeout=10)
            self._pause.set()
            return
        screen = self._main()
        if screen is None:
            return
        screen.refresh_status()
        if message.show:
            screen.keep_poles(message.poles)
            view = self.bench.view()
            screen.refresh_run(view, plots=False)
            screen.refresh_history(view)
            gc.freeze()

    def on_drawn(self, message: Drawn) -> None:
        """UI thread: the worker's plots, when they are of the current view (the worker
        is told once they are painted)."""
        screen = self._main()
        try:
            if screen is not None:
                screen.show_drawn(message.key, message.drawn, message.prebuilt)
        finally:
            self.call_after_refresh(self._painted.set)

    def on_run_ended(self, message: RunEnded) -> None:
        if message.note == "paused":
            self.bench.paused_at = self.bench.iteration
        try:
            self._run_done()
        finally:
            self.call_after_refresh(self._painted.set)
        if message.note == "paused":
            self.notify(f"paused at iteration {self.bench.iteration}", timeout=3)

    def on_run_failed(self, message: RunFailed) -> None:
        self._run_done()
        self.notify(message.error, title="iteration failed", severity="error", timeout=10)

    def _run_done(self) -> None:
        """The keys are enabled again; everything but the plots (drawn by the worker) is refreshed."""
        self.bench.autosave(wait=False)  # a long session's JSON: written off the UI thread
        self._set_running(False)
        self.refresh_workbench(plots=False)


def drawings(view: View, canvases: dict, only: set[str] | None = None) -> tuple[dict, dict]:
    """The figures of a view's plots on screen (``canvases``; ``only``: of these), and
    their text at the canvases' sizes (off the UI thread)."""
    drawn = figures(view, set(canvases) if only is None else only)
    return drawn, {name: FigurePlot.prebuild(drawn[name], canvas) for name, canvas in canvases.items() if name in drawn}


def _positive_integer(text: str) -> str | None:
    try:
        return None if int(float(text)) >= 1 else "at least 1"
    except (ValueError, OverflowError):
        return "a whole number"

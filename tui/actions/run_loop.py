"""The run loop: a thread worker computes, the UI thread commits.

`s`, `n` and `r` take the bound stepper and the current state from the
workbench on the UI thread, then a thread worker steps: each iteration it
computes the next (State, StepRecord) from its own state and view and posts
a `Stepped` message (marked to be shown a few times a second, and always the
last).  The UI thread alone appends the record (`RecordBook.commit`; its JSON made
by the worker),
autosaves and refreshes the tableau.  After a shown iteration, and once more
after the run, the worker draws the plots on screen from its own view (sizes
taken when the run began) and posts them (`Drawn`): the tableau never waits
for a plot.  After posting what the screen shows, the worker waits (at most
`PAINT_WAIT`) until the UI thread has painted it: a worker stepping on would
hold the GIL half the time and double every paint (the 50 ms timer waited
up to 180 ms).  `Ended` or `Failed` follows the last `Stepped` (messages
keep their order), and only then are the keys that change the session
enabled again, so an undo can never meet a record still on its way; plots
drawn for a view that is no longer current are dropped.
"""

from __future__ import annotations

import functools
import gc
import math
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

from textual.message import Message

from engine.stepping.protocol import State, Stepper, StepRecord
from sessions.errors import SessionError
from tui.figures.catalog import figure_key, figures
from tui.screens.pole_lines import every_break_text, under_tableau
from tui.state.bench.records import stored_json
from tui.state.views import View
from tui.widgets.plots import FigurePlot

if TYPE_CHECKING:
    from tui.app import LoopcraftApp

REDRAW_INTERVAL = 0.25  # while running, the plots are redrawn at most this often (s)
PAINT_WAIT = 0.3  # s: after posting what the screen shows, the worker waits at most this for its paint
BREAK_LINES_INTERVAL = 2.0  # while running, the loops at every break are made at most this often (s)


@dataclass
class RunRequest:
    """What the worker steps: the bound stepper, the state to step from, the view, how far."""

    stepper: Stepper
    state: State
    view: View
    count: int
    canvases: dict
    settings: dict | None  # the snapshot the records are kept with (`RecordBook.settings`)


class RunLoop:
    """`s`, `n`, `r` and pause, composed into the app (``app.runs``): its own state (whether
    a run goes, the pause request, the paint handshake), a thread worker that computes,
    and the handlers of the messages the worker posts back (nested here, handled by the
    app with ``@on``), which commit on the UI thread."""

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
            self.poles = (
                poles  # (figure_key, the pole lines under the tableau, the view), made in the worker when shown
            )

    class Drawn(Message):
        """The plots on screen drawn by the worker for the view of ``key`` (`figure_key`)."""

        def __init__(self, key: tuple, drawn: dict, prebuilt: dict):
            super().__init__()
            self.key, self.drawn, self.prebuilt = key, drawn, prebuilt

    class Ended(Message):
        """The worker stopped: finished, paused or the count reached (``note`` says which when it matters)."""

        def __init__(self, note: str | None = None):
            super().__init__()
            self.note = note

    class Failed(Message):
        """An iteration raised: the run stops, the records so far are kept."""

        def __init__(self, error: str):
            super().__init__()
            self.error = error

    def __init__(self, app: LoopcraftApp) -> None:
        self.app = app
        self.running = False
        self._pause = threading.Event()
        self._painted = threading.Event()  # set by the UI thread once it has painted what was posted

    def step(self) -> None:
        self.start(1)

    def run(self) -> None:
        self.start(10**9)

    def run_n(self) -> None:
        from tui.screens.dialogs import EditDialog

        def chosen(text: str | None) -> None:
            if text:
                self.start(int(float(text)))

        self.app.push_screen(EditDialog("run how many iterations?", "10", _positive_integer), chosen)

    def pause(self) -> None:
        self._pause.set()

    def start(self, count: int) -> None:
        app = self.app
        if app.bench is None or app.busy:
            return
        try:
            stepper, state = self.app.bench.begin_run()
        except SessionError as exc:
            self.app.notify(str(exc), title="cannot run", severity="error", timeout=10)
            return
        if state.status.finished:
            self.app.notify("the algorithm has finished; z undoes, a changes it")
            return
        screen = self.app.main_screen()
        request = RunRequest(
            stepper,
            state,
            self.app.bench.view(),
            count,
            screen.canvases() if screen else {},
            self.app.bench.settings,
        )
        self._pause.clear()
        self._painted.clear()
        self._set_running(True)
        self.app.call_after_refresh(self._painted.set)
        self.app.run_worker(
            functools.partial(self._work, request), thread=True, exclusive=True, exit_on_error=False, group="run"
        )

    def _set_running(self, running: bool) -> None:
        self.running = running
        self.app.busy_changed()

    def _work(self, request: RunRequest) -> None:
        """The worker thread's body (`start` runs it): step, post back, stop when asked."""
        gc.freeze()  # a full collection then scans only what is new, not a long session's records
        try:
            note, view, drawn = self._steps(request)
        except Exception as exc:  # noqa: BLE001 - an engine failure ends the run, never the app
            self.app.post_message(self.Failed(f"{type(exc).__name__}: {exc}"))
            return
        finally:
            gc.unfreeze()
        self._painted.clear()
        self.app.post_message(self.Ended(note))
        if view is not None and not drawn:
            self._painted.wait(PAINT_WAIT)  # the keys come back and are painted first
            self._post_drawings(view, request.canvases)

    def _steps(self, request: RunRequest) -> tuple[str | None, View | None, bool]:
        """In the worker: step, post every record, draw now and then; why it stopped,
        the last view and whether its plots were drawn."""
        state, view, last, drawn = request.state, request.view, 0.0, True
        breaks = (-math.inf, 0, "")  # when the loops at every break were made, at which iteration, their lines
        self._painted.wait(PAINT_WAIT)  # the screen as the run starts is painted first
        for n in range(request.count):
            if self._pause.is_set():
                return "paused", view, drawn
            state, record = request.stepper.step(state)
            view = view.extended(record)
            final = record.status.finished or n == request.count - 1
            show = final or time.monotonic() - last >= REDRAW_INTERVAL
            self._painted.clear()
            poles = None
            if show:
                if final or time.monotonic() - breaks[0] >= BREAK_LINES_INTERVAL:
                    breaks = (time.monotonic(), record.iteration, every_break_text(view))
                poles = (figure_key(view), under_tableau(view, _dated(breaks, record.iteration)), view)
            self.app.post_message(
                self.Stepped(state, record, show, stored_json(state, record, request.settings), poles)
            )
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
        self.app.post_message(self.Drawn(figure_key(view), *drawings(view, canvases)))

    def stepped(self, message: RunLoop.Stepped) -> None:
        """UI thread: keep the record, then show it in the tableau when asked (and
        tell the worker once it is painted)."""
        try:
            self._show_stepped(message)
        finally:
            if message.show:
                self.app.call_after_refresh(self._painted.set)

    def _show_stepped(self, message: RunLoop.Stepped) -> None:
        try:
            self.app.bench.commit(message.state, message.record, message.stored)
        except SessionError as exc:  # cannot happen while changes are disabled; said, never silent
            self.app.notify(str(exc), title="record not kept", severity="error", timeout=10)
            self._pause.set()
            return
        screen = self.app.main_screen()
        if screen is None:
            return
        screen.refresh_status()
        if message.show:
            screen.pole_lines.keep(message.poles)
            view = self.app.bench.view()
            screen.refresh_run(view, plots=False)
            screen.refresh_history(view)
            gc.freeze()

    def drawn(self, message: RunLoop.Drawn) -> None:
        """UI thread: the worker's plots, when they are of the current view (the worker
        is told once they are painted)."""
        screen = self.app.main_screen()
        try:
            if screen is not None:
                screen.show_drawn(message.key, message.drawn, message.prebuilt)
        finally:
            self.app.call_after_refresh(self._painted.set)

    def ended(self, message: RunLoop.Ended) -> None:
        if message.note == "paused":
            self.app.bench.paused_at = self.app.bench.iteration
        try:
            self._run_done()
        finally:
            self.app.call_after_refresh(self._painted.set)
        if message.note == "paused":
            self.app.notify(f"paused at iteration {self.app.bench.iteration}", timeout=3)

    def failed(self, message: RunLoop.Failed) -> None:
        self._run_done()
        self.app.notify(message.error, title="iteration failed", severity="error", timeout=10)

    def _run_done(self) -> None:
        """The keys are enabled again; everything but the plots (drawn by the worker) is refreshed."""
        self.app.bench.file.autosave(wait=False)  # a long session's JSON: written off the UI thread
        self._set_running(False)
        self.app.refresh_workbench(plots=False)


def drawings(
    view: View,
    canvases: dict,
    only: set[str] | None = None,
    held: dict | None = None,
    coarse: bool = False,
) -> tuple[dict, dict]:
    """The figures of a view's plots on screen (``canvases``; ``only``: of these), and
    their text at the canvases' sizes in the plots' held views (``held``: `FigurePlot.held`
    by plot id; none: the whole figure), off the UI thread; ``coarse``: a drag's frame
    (`figures`)."""
    drawn = figures(view, set(canvases) if only is None else only, coarse=coarse)
    held = held or {}
    return drawn, {
        name: FigurePlot.prebuild(drawn[name], canvas, held.get(name, (None, None)))
        for name, canvas in canvases.items()
        if name in drawn
    }


def _positive_integer(text: str) -> str | None:
    try:
        return None if int(float(text)) >= 1 else "at least 1"
    except (ValueError, OverflowError):
        return "a whole number"


def _dated(breaks: tuple[float, int, str], iteration: int) -> str:
    """The loops at every break made during a run, said to be of an earlier iteration when they are."""
    _, made_at, lines = breaks
    if not lines or made_at == iteration:
        return lines
    return f"{lines}\n(at iteration {made_at}: made every {BREAK_LINES_INTERVAL:g} s while running)"

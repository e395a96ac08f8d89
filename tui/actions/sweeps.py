"""The app's sweeps, composed into the app (``app.sweeps``): ask for a sweep, run
it on Dask in a thread worker (the session is only read there: every change is
disabled meanwhile), keep the summary on the UI thread, adopt the best optimum (or a
tolerance study's worst sample, to look at).
The worker's way back is posted messages (nested here, handled by the app)."""

from __future__ import annotations

import functools
import threading
from typing import TYPE_CHECKING

from textual.message import Message

from engine.stepping.presenter import number
from sessions.errors import SessionError
from sessions.sweeps.dispersion import run_count
from sessions.sweeps.plan import parse_sweep

if TYPE_CHECKING:
    from tui.app import LoopcraftApp

SWEEP_PROMPT = (
    "sweep: starts N [spread F] [seed S] | vary NAME=V1,V2,... | tolerance NAME=+-10% NAME=normal:5% "
    "[samples N] [sampling lhs] [seed S]; end with 'at tcp://HOST:PORT' for a cluster"
)


def sample_values(values: dict) -> str:
    """A sample's drawn values, NAME=V (a value per flight condition: V1/V2/...)."""
    return "  ".join(
        f"{name}=" + ("/".join(number(float(v), 4) for v in value) if isinstance(value, list) else number(value, 4))
        for name, value in values.items()
    )


class Sweeps:
    """`w` starts a sweep, space cancels it, `u` adopts its best run (a tolerance study's
    worst sample of the row highlighted)."""

    class Progress(Message):
        """How far the sweep is (a line for the Sweep tab)."""

        def __init__(self, text: str) -> None:
            super().__init__()
            self.text = text

    class Done(Message):
        """The sweep's summary (not yet kept: the UI thread keeps it)."""

        def __init__(self, summary: dict) -> None:
            super().__init__()
            self.summary = summary

    class Failed(Message):
        """The sweep could not run (a cluster out of reach, a broken session)."""

        def __init__(self, error: str) -> None:
            super().__init__()
            self.error = error

    def __init__(self, app: LoopcraftApp) -> None:
        self.app = app
        self.sweeping = False
        self._cancel = threading.Event()

    def ask(self) -> None:
        """Ask for a sweep (one line), then run it on Dask in a worker thread."""
        from tui.screens.dialogs import EditDialog

        app = self.app
        if app.bench is None or app.busy:
            return

        def check(text: str) -> str | None:
            try:
                parse_sweep(text)
            except SessionError as exc:
                return str(exc)
            return None

        def chosen(text: str | None) -> None:
            if not text or app.busy:
                return
            self._cancel.clear()
            self.sweeping = True
            app.busy_changed()
            screen = app.main_screen()
            if screen is not None:
                screen.action_tab("sweep")
                screen.refresh_sweep()  # the tab as the session has it (a hidden tab is redrawn when shown)
                screen.refresh_sweep(f"sweep {text}: starting the cluster ...  (space cancels)")
            app.run_worker(
                functools.partial(self._work, text), thread=True, exclusive=True, exit_on_error=False, group="sweep"
            )

        app.push_screen(EditDialog(SWEEP_PROMPT, "starts 16", check), chosen)

    def cancel(self) -> None:
        self._cancel.set()

    def _work(self, text: str) -> None:
        """The worker thread's body: the sweep, its progress and its end posted back."""
        app = self.app

        def progress(done: int, total: int) -> None:
            app.post_message(self.Progress(f"sweep {text}: {done}/{total} runs  (space cancels)"))

        try:
            summary = app.bench.sweeps.run(text, progress, self._cancel.is_set)
        except Exception as exc:  # noqa: BLE001 - a cluster that cannot be reached must not close the app
            app.post_message(self.Failed(f"{type(exc).__name__}: {exc}"))
            return
        app.post_message(self.Done(summary))

    def progressed(self, message: Sweeps.Progress) -> None:
        screen = self.app.main_screen()
        if screen is not None:
            screen.refresh_sweep(message.text)

    def failed(self, message: Sweeps.Failed) -> None:
        self.sweeping = False
        self.app.busy_changed()
        self.app.notify(message.error, title="sweep failed", severity="error", timeout=10)
        self.app.refresh_workbench()

    def done(self, message: Sweeps.Done) -> None:
        summary = message.summary
        self.sweeping = False
        self.app.bench.sweeps.keep(summary)
        self.app.busy_changed()
        self.app.refresh_workbench()
        self.app.notify(f"sweep done: {run_count(summary)}, {len(summary['optima'])} optima")

    def use_best(self) -> None:
        """Adopt the latest sweep's best run as the session's start, or a tolerance study's
        worst sample of the row highlighted, to look at (asks when iterations would go)."""
        app = self.app
        if app.bench is None or app.bench.sweeps.refusal() is not None:
            return
        if app.bench.sweeps.latest()["kind"] == "tolerance":
            self._use_worst()
            return
        app.edit_flow.change(
            app.bench.sweeps.adopt_best,
            "use the best optimum's design as the start",
            keeps_design=False,
            done=lambda run: app.notify(
                "\n".join([f"the start is now run {run['index']}'s design", *run.get("widened", [])])
            ),
        )

    def _use_worst(self) -> None:
        app = self.app
        screen = app.main_screen()
        row = screen.sweep_row() if screen is not None else 0

        def adopted(run: dict) -> None:
            chosen = run["row"]
            values = sample_values(run["start"])
            lines = [f"the start is now sample {run['index']}, the worst of {chosen['name']} at {chosen['condition']}"]
            app.notify("\n".join([*lines, values, *run.get("widened", [])]))

        app.edit_flow.change(
            lambda: app.bench.sweeps.adopt_worst(row),
            "open the tolerance study's worst sample as the start",
            keeps_design=False,
            done=adopted,
        )

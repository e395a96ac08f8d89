"""The app's sweep actions: ask for a sweep, run it on Dask in a thread worker
(the session is only read there: every change is disabled meanwhile), keep
the summary on the UI thread, adopt the best optimum."""

from __future__ import annotations

from textual import work

from sessions.errors import SessionError
from sessions.sweeps.plan import parse_sweep

SWEEP_PROMPT = (
    "sweep: starts N [spread F] [seed S] | vary NAME=V1,V2,... | tolerance NAME=+-10% [samples N]; "
    "end with 'at tcp://HOST:PORT' for a cluster"
)


class SweepActions:
    """`w` starts a sweep, `u` adopts its best run (a mixin of the app)."""

    sweeping = False

    def action_sweep(self) -> None:
        """Ask for a sweep (one line), then run it on Dask in a worker thread."""
        from tui.screens.dialogs import EditDialog

        if self.bench is None or self.busy:
            return

        def check(text: str) -> str | None:
            try:
                parse_sweep(text)
            except SessionError as exc:
                return str(exc)
            return None

        def chosen(text: str | None) -> None:
            if not text or self.busy:
                return
            self._sweep_cancel = False
            self.sweeping = True
            self._set_running(self.running)
            screen = self._main()
            if screen is not None:
                screen.action_tab("sweep")
                screen.refresh_sweep(f"sweep {text}: starting the cluster ...  (space cancels)")
            self._sweep_worker(text)

        self.push_screen(EditDialog(SWEEP_PROMPT, "starts 16", check), chosen)

    @work(thread=True, exclusive=True, exit_on_error=False, group="sweep")
    def _sweep_worker(self, text: str) -> None:
        def progress(done: int, total: int) -> None:
            self.call_from_thread(self._sweep_progress, f"sweep {text}: {done}/{total} runs  (space cancels)")

        try:
            summary = self.bench.run_sweep(text, progress, lambda: self._sweep_cancel)
        except Exception as exc:  # noqa: BLE001 - a cluster that cannot be reached must not close the app
            self.call_from_thread(self._sweep_failed, f"{type(exc).__name__}: {exc}")
            return
        self.call_from_thread(self._swept, summary)

    def _sweep_progress(self, text: str) -> None:
        screen = self._main()
        if screen is not None:
            screen.refresh_sweep(text)

    def _sweep_failed(self, error: str) -> None:
        self.sweeping = False
        self._set_running(self.running)
        self.notify(error, title="sweep failed", severity="error", timeout=10)
        self.refresh_workbench()

    def _swept(self, summary: dict) -> None:
        self.sweeping = False
        self.bench.keep_sweep(summary)
        self._set_running(self.running)
        self.refresh_workbench()
        self.notify(f"sweep done: {len(summary['runs'])} runs, {len(summary['optima'])} optima")

    def action_use_best(self) -> None:
        """Adopt the latest sweep's best run as the session's start (asks when iterations would go)."""
        if self.bench is None or self.bench.latest_sweep() is None:
            return
        self.edit_flow.change(
            self.bench.adopt_best,
            "use the best optimum's design as the start",
            done=lambda run: self.notify(f"the start is now run {run['index']}'s design"),
        )

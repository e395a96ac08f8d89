"""The closed-loop pole lines under the Run tab's tableau, made off the UI thread
(a launch vehicle's take 25 ms; they were made on it five times per step): by
the run's worker for the steps it shows (`tui.actions.run_loop.Stepped`), else by a
thread worker, the tableau drawn again when they come.  The lines of one view
are kept, with the view (the ids in its `figure_key` stay taken)."""

from __future__ import annotations

from tui.figures.catalog import figure_key
from tui.figures.closed_loop import pole_text
from tui.state.views import View

COMPUTING = "closed-loop poles: computing ..."


class PoleLines:
    """Mixin of the main screen (which has ``bench``, ``refresh_run``, ``poles`` and ``_poles_asked``)."""

    def _pole_text(self, view: View) -> str:
        """The pole lines of ``view``: kept, or asked of a thread worker (`COMPUTING` meanwhile)."""
        if "poles" not in view.presenter.plots:
            return ""
        key = figure_key(view)
        if self.poles is not None and self.poles[0] == key:
            return self.poles[1]
        if self._poles_asked != key:
            self._poles_asked = key

            def compute() -> None:
                text = pole_text(view)
                self.app.call_from_thread(self._poles_found, view, text)

            self.run_worker(compute, thread=True, exclusive=True, group="poles")
        return COMPUTING

    def _poles_found(self, view: View, text: str) -> None:
        key = figure_key(view)
        if self._poles_asked == key:
            self._poles_asked = None
        if key == figure_key(self.bench.view()):
            self.keep_poles((key, text, view))
            self.refresh_run(plots=False)

    def keep_poles(self, poles: tuple[tuple, str, View] | None) -> None:
        """Keep the pole lines of one view (from the run's worker, or a thread worker)."""
        if poles is not None:
            self.poles = poles

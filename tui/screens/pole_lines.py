"""The closed-loop pole lines under the Run tab's tableau, and the loops at every break of
a condition with several (`tui.state.tableau_text.break_lines`: 0.1 to 1 s on the launch
vehicle), made off the UI thread (a launch vehicle's pole lines take 25 ms; they were made
on it five times per step): by
the run's worker for the steps it shows (`tui.actions.run_loop.RunLoop.Stepped`),
else by a thread worker, which posts them back (`PoleLines.Found`), the tableau
drawn again when they come.  The lines of one view are kept, with the view.  A part composed into the main screen
(``screen.pole_lines``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from textual.message import Message

from engine.stepping.presenter import tolerant
from tui.figures.catalog import figure_key
from tui.figures.closed_loop import pole_text
from tui.state.tableau_text import break_lines
from tui.state.views import View

if TYPE_CHECKING:
    from tui.screens.main import MainScreen

COMPUTING = "closed-loop poles, loops at every break: computing ..."


def several_breaks(view: View) -> bool:
    """Whether the first plotted condition names breaks beyond its primary one."""
    conditions = view.problem.conditions
    return bool(conditions) and conditions[view.first_plotted].several_breaks


def under_tableau(view: View, breaks: str | None = None) -> str:
    """The lines under the tableau (any thread, never raising): the closed-loop poles when the
    presenter shows them, the loops at every break of the first plotted condition (``breaks``:
    those lines made already, `every_break_text`)."""
    breaks = every_break_text(view) if breaks is None else breaks
    return "\n\n".join(part for part in (pole_text(view), breaks) if part)


def every_break_text(view: View) -> str:
    """The loops at every break of the first plotted condition ('' with one break; any thread,
    never raising; 0.1-0.9 s on the launch vehicle)."""
    if not several_breaks(view):
        return ""
    k = view.first_plotted
    return tolerant(lambda: break_lines(view.problem, k, view.parameters(None, k)), lambda: "")


class PoleLines:
    """The pole lines of the view on screen: kept, or asked of a thread worker."""

    class Found(Message):
        """A thread worker's pole lines for a view."""

        def __init__(self, view: View, text: str) -> None:
            super().__init__()
            self.view, self.text = view, text

    def __init__(self, screen: MainScreen) -> None:
        self.screen = screen
        self.kept: tuple[tuple, str, View] | None = None  # (`figure_key`, the lines, the view)
        self._asked: tuple | None = None  # the `figure_key` a thread worker makes lines for

    def text(self, view: View) -> str:
        """The pole lines of ``view``: kept, or asked of a thread worker (meanwhile `COMPUTING`
        on as many lines as the lines kept, or nothing when the lines kept are none, as a
        tabulated loop's are: a nudge's tableau keeps its height, and the screen no layout pass)."""
        if "poles" not in view.presenter.plots and not several_breaks(view):
            return ""
        key = figure_key(view)
        if self.kept is not None and self.kept[0] == key:
            return self.kept[1]
        lines = self.kept[1].count("\n") if self.kept is not None else 0
        if self._asked != key:
            self._asked = key

            def compute() -> None:
                self.screen.post_message(self.Found(view, under_tableau(view)))

            self.screen.after_paint(lambda: self.screen.run_worker(compute, thread=True, exclusive=True, group="poles"))
        return "" if self.kept is not None and not self.kept[1] else COMPUTING + "\n" * lines

    def found(self, message: PoleLines.Found) -> None:
        key = figure_key(message.view)
        if self._asked == key:
            self._asked = None
        if key == figure_key(self.screen.bench.view()):
            self.keep((key, message.text, message.view))
            self.screen.refresh_tableau()

    def keep(self, poles: tuple[tuple, str, View] | None) -> None:
        """Keep the pole lines of one view (from the run's worker, or a thread worker)."""
        if poles is not None:
            self.kept = poles

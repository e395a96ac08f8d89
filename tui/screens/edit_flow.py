"""The dialogs around a change of the problem: choose a field, type the value
(checked as it is typed), confirm when recorded iterations would be dropped,
apply it as a transaction, say what happened, refresh the screen."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from sessions.errors import SessionError
from tui.screens.dialogs import ChooseDialog, ConfirmDialog, EditDialog, StartDialog
from tui.state.edits import Check, Edit

if TYPE_CHECKING:
    from tui.app import LoopcraftApp
    from tui.state.workbench import Workbench


class EditFlow:
    """Runs edits for the table widgets; one per app."""

    def __init__(self, app: LoopcraftApp) -> None:
        self.app = app

    @property
    def bench(self) -> Workbench:
        bench = self.app.bench
        if bench is None:  # an edit comes from a table of an open session only
            raise SessionError("no session is open")
        return bench

    def choose(
        self, title: str, choices: list[tuple[str, str]], then: Callable[[str], None], highlighted: int = 0
    ) -> None:
        """Pick one of several names (``highlighted`` first), then go on with it."""

        def chosen(name: str | None) -> None:
            if name:
                then(name)

        self.app.push_screen(ChooseDialog(title, choices, highlighted), chosen)

    def open(self, edit: Edit | None) -> None:
        """Ask for the new text of a value (asking first when iterations would go), then apply it."""
        if edit is None:
            self.app.notify("this row has nothing to edit here", severity="warning")
            return

        self._ask(edit.title, edit.text, edit.check, edit.apply, "this edit changes the problem", empty=True)

    def _ask(
        self,
        title: str,
        text: str,
        check: Check | None,
        apply: Callable[[str], object],
        what: str,
        error: str = "",
        empty: bool = False,
    ) -> None:
        """The edit dialog (``empty``: an empty line is a value too); an edit refused when
        applied opens it again with the typed text and the reason under it."""

        def typed(typed_text: str | None) -> None:
            if typed_text or (empty and typed_text is not None):
                self.change(
                    lambda: apply(typed_text),
                    what,
                    failed="the old value is kept",
                    refused=lambda reason: self._ask(title, typed_text, check, apply, what, reason, empty),
                )

        self.app.push_screen(EditDialog(title, text, check, error), typed)

    def ask(self, title: str, check: Check | None, then: Callable[[str], None]) -> None:
        """Ask for one line, then go on with it (nothing changed yet)."""

        def typed(text: str | None) -> None:
            if text:
                then(text)

        self.app.push_screen(EditDialog(title, "", check), typed)

    def line(self, title: str, check: Check | None, apply: Callable[[str], object], what: str) -> None:
        """Ask for one line (e.g. a new parameter) and apply it."""
        self._ask(title, "", check, apply, what)

    def change(
        self,
        change: Callable[[], object],
        what: str,
        always_ask: bool = False,
        failed: str = "nothing changed",
        done: Callable[[object], None] | None = None,
        refused: Callable[[str], None] | None = None,
        keeps_design: bool = True,
        burst: object = None,
    ) -> None:
        """Apply a change of the problem.  When it drops recorded iterations, the design on
        screen becomes the start first (``keeps_design``; the session's first such edit asks,
        with the saved start as the other answer, and the answer holds: `Workbench.start`);
        a deletion (``always_ask``) is confirmed.  A failure changes nothing and is reported
        (to ``refused`` when given, else as a notification).  Edits of one ``burst`` (a
        shaping key held on one item) are one undo step (`EditHistory.push`)."""
        iterations = self.bench.iteration
        adopting = keeps_design and iterations > 0

        def apply(start: str | None = "design") -> None:
            if start is None:
                return
            if adopting:
                self.bench.start = start

            def adopted_then_changed() -> object:
                if adopting and start == "design":
                    self.bench.book.adopt_current()
                return change()

            try:  # one undo step, put back whole when refused
                result = self.bench.book.edit(adopted_then_changed, burst)
            except (SessionError, ValueError) as exc:
                if refused is not None:
                    refused(f"not applied ({failed}): {exc}")
                else:
                    self.app.notify(str(exc), title=f"not applied: {failed}", severity="error", timeout=10)
            else:
                # an accepted edit is never only in memory: written by the autosave thread, in
                # order, while the UI thread paints (waiting for it held a nudge's paint)
                self.bench.file.autosave(throttled=True, wait=False)
                if adopting:
                    self.app.notify(_dropped(iterations, start), timeout=6)
                if done is not None:
                    done(result)
            self.app.refresh_workbench()

        if adopting and self.bench.start is None:
            question = f"{what}: {_recorded(iterations)} dropped (ctrl+z undoes the edit). Start from?"
            self.app.push_screen(StartDialog(question), apply)
        elif always_ask or (iterations and not keeps_design):
            dropped = f"; {_recorded(iterations)} will be dropped (ctrl+z undoes the edit)" if iterations else ""
            answer = self.bench.start or "design"
            self.app.push_screen(ConfirmDialog(f"{what}{dropped}?"), lambda yes: apply(answer if yes else None))
        else:
            apply(self.bench.start or "design")


def _dropped(iterations: int, start: str) -> str:
    """What an edit did to the recorded iterations and the start."""
    kept = f"iteration {iterations}'s design is the start" if start == "design" else "back to the saved start"
    return f"{_recorded(iterations)} dropped; {kept} (ctrl+z undoes the edit)"


def _recorded(iterations: int) -> str:
    """The recorded iterations, named: 'iteration 1', 'iterations 1-3'."""
    return "iteration 1" if iterations == 1 else f"iterations 1-{iterations}"

"""The dialogs around a change of the problem: choose a field, type the value
(checked as it is typed), confirm when recorded iterations would be dropped,
apply it as a transaction, say what happened, refresh the screen."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sessions.errors import SessionError
from tui.screens.dialogs import ChooseDialog, ConfirmDialog, EditDialog
from tui.state.edit_history import Snapshot
from tui.state.edits import Check, Edit


class EditFlow:
    """Runs edits for the table widgets; one per app."""

    def __init__(self, app: Any):
        self.app = app

    @property
    def bench(self):
        return self.app.bench

    def choose(self, title: str, choices: list[tuple[str, str]], then: Callable[[str], None]) -> None:
        """Pick one of several names, then go on with it."""
        self.app.push_screen(ChooseDialog(title, choices), lambda name: name and then(name))

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
        apply: Callable[[str], Any],
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

    def line(self, title: str, check: Check | None, apply: Callable[[str], Any], what: str) -> None:
        """Ask for one line (e.g. a new parameter) and apply it."""
        self._ask(title, "", check, apply, what)

    def change(
        self,
        change: Callable[[], Any],
        what: str,
        always_ask: bool = False,
        failed: str = "nothing changed",
        done: Callable[[Any], None] | None = None,
        refused: Callable[[str], None] | None = None,
    ) -> None:
        """Apply a change of the problem; ask first when iterations would be dropped
        (or always, for deletions).  A failure changes nothing and is reported (to
        ``refused`` when given, else as a notification)."""
        iterations = self.bench.iteration

        def apply(yes: bool | None = True) -> None:
            if not yes:
                return
            before = Snapshot.of(self.bench)
            try:
                result = change()
            except (SessionError, ValueError) as exc:
                if refused is not None:
                    refused(f"not applied ({failed}): {exc}")
                else:
                    self.app.notify(str(exc), title=f"not applied: {failed}", severity="error", timeout=10)
            else:
                self.bench.edits.push(before, self.bench)
                self.bench.autosave(throttled=True)  # an accepted edit is never only in memory
                if done is not None:
                    done(result)
            self.app.refresh_workbench()

        if iterations or always_ask:
            dropped = (
                f"; the {iterations} recorded iteration(s) will be dropped (save first to keep them)"
                if iterations
                else ""
            )
            self.app.push_screen(ConfirmDialog(f"{what}{dropped}?"), apply)
        else:
            apply()

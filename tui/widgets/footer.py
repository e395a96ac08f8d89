"""The key footer, rebuilt once for every binding refresh made before its rebuild.

Textual's `Footer` rebuilds itself (some twenty keys with their styles: 10-20 ms
at 120x40) after the next screen refresh each time the screen's bindings are
refreshed; a step's end refreshes them more than once (the run's keys enabled
again, the workbench redrawn), and each rebuild came after the other, between
the key press and the painted iteration."""

from __future__ import annotations

from textual.screen import Screen
from textual.widgets import Footer as TextualFooter


class Footer(TextualFooter):
    """`textual.widgets.Footer` with one rebuild pending at most (it reads the bindings as they are then)."""

    _rebuild_due = False

    def bindings_changed(self, screen: Screen) -> None:
        if self._rebuild_due:
            return
        super().bindings_changed(screen)
        self._rebuild_due = bool(screen.app.app_focus and self.is_attached and screen is self.screen)

    async def recompose(self) -> None:
        self._rebuild_due = False
        await super().recompose()

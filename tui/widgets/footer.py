"""The key footer, rebuilt once for every binding refresh made before its rebuild.

Textual's `Footer` rebuilds itself (some twenty keys with their styles: 10-20 ms
at 120x40) after the next screen refresh each time the screen's bindings are
refreshed; a step's end refreshes them more than once (the run's keys enabled
again, the workbench redrawn), and each rebuild came after the other, between
the key press and the painted iteration.  Here every refresh still asks for a
rebuild, as Textual's does (one that is dropped, say with a screen popped
before it ran, is made up by the next), and a rebuild for bindings the footer
was already built for does nothing, nor one that would show the same keys: a
nudge in the shaping table refreshes the bindings (the workbench redrawn) but
changes no key, and its rebuild was 7 % of a nudge's time.  A disabled key's
tooltip says why it cannot act now (the app's `key_reason`), as pressing it does."""

from __future__ import annotations

from textual.app import ComposeResult
from textual.screen import Screen
from textual.widgets import Footer as TextualFooter


class Footer(TextualFooter):
    """`textual.widgets.Footer` that skips a rebuild for bindings it already shows."""

    _asked = 0  # binding refreshes seen
    _built = -1  # the refresh the footer was last built after
    _shown: tuple = ()  # the keys it shows: (key, action, description, enabled, tooltip) of each

    def bindings_changed(self, screen: Screen) -> None:
        self._asked += 1
        super().bindings_changed(screen)

    async def recompose(self) -> None:
        if self._built == self._asked:
            return  # built after the latest refresh already (it reads the bindings as they are then)
        self._built = self._asked
        if not self.is_attached:  # its screen gone (popped before the rebuild ran): nothing to show
            return
        shown = self._keys()
        if shown == self._shown and self.children:
            return  # the same keys, each as enabled as before
        self._shown = shown
        await super().recompose()

    def _keys(self) -> tuple:
        """What the footer would show: each shown binding's key, action, description,
        whether it is enabled, and its tooltip (a disabled key's: why, `key_reason`)."""
        reason_of = getattr(self.app, "key_reason", lambda _: None)
        return tuple(
            (key, b.action, b.description, enabled, tooltip if enabled else (tooltip, reason_of(b.action)))
            for key, (_, b, enabled, tooltip) in self.screen.active_bindings.items()
            if b.show
        )

    def compose(self) -> ComposeResult:
        reason_of = getattr(self.app, "key_reason", lambda _: None)
        for widget in super().compose():
            action = getattr(widget, "action", None)  # a key (Textual's FooterKey, not exported)
            if action and widget.has_class("-disabled"):
                reason = reason_of(action)
                if reason:
                    widget.tooltip = f"{getattr(widget, 'description', '') or action}: {reason}"
            yield widget

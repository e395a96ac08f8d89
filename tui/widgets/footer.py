"""The key footer, rebuilt only when the keys it shows change.

Textual's `Footer` recomposes itself (some twenty keys with their styles: 10-20 ms
at 120x40) after the next screen refresh each time the screen's bindings are
refreshed; a step's end refreshes them more than once (the run's keys enabled
again, the workbench redrawn), and a nudge in the shaping table refreshes them
(the workbench redrawn) while changing no key.  Here a refresh schedules a check
instead, after the next screen refresh, as Textual schedules its rebuild: the
checks of refreshes made before one ran do nothing (one that is dropped, say with
a screen popped before it ran, is made up by the next), and the footer is
recomposed only when the keys it would show differ from those it shows (each
key's action, description, whether it is enabled, its tooltip).  A disabled
key's tooltip says why it cannot act now (the app's `key_reason` of the widget the key
belongs to: the shaping table's `[` on its gain row names the pair it needs), as pressing it does."""

from __future__ import annotations

from textual.app import ComposeResult
from textual.screen import Screen
from textual.widgets import Footer as TextualFooter


class Footer(TextualFooter):
    """`textual.widgets.Footer` recomposed only when its keys change."""

    _asked = 0  # binding refreshes seen
    _checked = -1  # the refresh the keys were last checked after
    _shown: tuple = ()  # the keys it shows (`_keys`), set when composed

    def bindings_changed(self, screen: Screen) -> None:
        """Textual's, with a check of the keys in place of the recompose."""
        self._asked += 1
        self._bindings_ready = True
        if screen.app.app_focus and self.is_attached and screen is self.screen:
            self.call_after_refresh(self._rebuild_if_changed)

    async def _rebuild_if_changed(self) -> None:
        if self._checked == self._asked:
            return  # checked after the latest refresh already (it read the bindings as they are then)
        self._checked = self._asked
        if not self.is_attached:  # its screen gone (popped before the check ran): nothing to show
            return
        if self._keys() == self._shown and self.children:
            return  # the same keys, each as enabled as before
        await self.recompose()

    def _keys(self) -> tuple:
        """What the footer would show: each shown binding's key, action, description,
        whether it is enabled, and its tooltip (a disabled key's: why, `key_reason`)."""
        reason_of = getattr(self.app, "key_reason", lambda *_: None)
        return tuple(
            (key, b.action, b.description, enabled, tooltip if enabled else (tooltip, reason_of(b.action, node)))
            for key, (node, b, enabled, tooltip) in self.screen.active_bindings.items()
            if b.show
        )

    def compose(self) -> ComposeResult:
        if self._bindings_ready:
            self._shown = self._keys()  # what this composition shows, whoever asked for it
        reason_of = getattr(self.app, "key_reason", lambda *_: None)
        owners = {b.action: node for node, b, enabled, _ in self.screen.active_bindings.values() if not enabled}
        for widget in super().compose():
            action = getattr(widget, "action", None)  # a key (Textual's FooterKey, not exported)
            if action and widget.has_class("-disabled"):
                reason = reason_of(action, owners.get(action))
                if reason:
                    widget.tooltip = f"{getattr(widget, 'description', '') or action}: {reason}"
            yield widget

"""A text widget that repaints without a layout pass when its text changes
(unlike `Static.update`), so a run's steady updates stay cheap; its height
follows the number of lines only when that number changes; the same text set again is
not repainted."""

from __future__ import annotations

from rich.text import Text
from textual.widget import Widget


class TextView(Widget):
    DEFAULT_CSS = "TextView { height: auto; text-wrap: nowrap; text-overflow: clip; }"

    def __init__(self, text: str | Text = "", **kwargs):
        super().__init__(**kwargs)
        self._text = Text.from_markup(text) if isinstance(text, str) else text
        self._lines = self._text.plain.count("\n") + 1

    def set(self, text: str | Text) -> None:
        """Show ``text``; the same text again (a nudge's unchanged step lines) is not repainted."""
        new = Text.from_markup(text) if isinstance(text, str) else text
        if new is not self._text and _same(new, self._text):  # (the same object may have been changed)
            return
        self._text = new
        lines = new.plain.count("\n") + 1
        self.refresh(layout=lines != self._lines)
        self._lines = lines

    @property
    def text(self) -> Text:
        """What it shows."""
        return self._text

    def render(self) -> Text:
        return self._text


def _same(a: Text, b: Text) -> bool:
    """Whether two texts draw the same: their characters, spans and how they are laid out."""
    laid_out = ("style", "justify", "overflow", "no_wrap", "end", "tab_size")
    return a.plain == b.plain and a.spans == b.spans and all(getattr(a, k) == getattr(b, k) for k in laid_out)

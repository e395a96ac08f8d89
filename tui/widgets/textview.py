"""A text widget that repaints without a layout pass when its text changes
(unlike `Static.update`), so a run's steady updates stay cheap; its height
follows the number of lines only when that number changes, and the same text
set again repaints nothing (a drag's frames set the status line and the step's
lines to what they show)."""

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
        text = Text.from_markup(text) if isinstance(text, str) else text
        if text == self._text and text.style == self._text.style:  # the characters, their spans, the base style
            return
        self._text = text
        lines = self._text.plain.count("\n") + 1
        self.refresh(layout=lines != self._lines)
        self._lines = lines

    @property
    def text(self) -> Text:
        """What it shows."""
        return self._text

    def render(self) -> Text:
        return self._text

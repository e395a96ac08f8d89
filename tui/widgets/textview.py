"""A text widget that repaints without a layout pass when its text changes
(unlike `Static.update`), so a run's steady updates stay cheap; its height
follows the number of lines only when that number changes."""

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
        self._text = Text.from_markup(text) if isinstance(text, str) else text
        lines = self._text.plain.count("\n") + 1
        self.refresh(layout=lines != self._lines)
        self._lines = lines

    @property
    def text(self) -> Text:
        """What it shows."""
        return self._text

    def render(self) -> Text:
        return self._text

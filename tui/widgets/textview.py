"""A text widget that repaints only the lines whose text changed (Textual's line API:
`render_line`), without a layout pass unless its number of lines changes (unlike
`Static.update`), so a run's steady updates and a nudge's new tableau stay cheap; the
same text set again is not repainted."""

from __future__ import annotations

from rich.text import Text
from textual.geometry import Region, Size
from textual.strip import Strip
from textual.visual import RichVisual, Visual, visualize
from textual.widget import Widget


class TextView(Widget):
    DEFAULT_CSS = "TextView { height: auto; text-wrap: nowrap; text-overflow: clip; }"

    def __init__(self, text: str | Text = "", **kwargs):
        super().__init__(**kwargs)
        self._text = Text.from_markup(text) if isinstance(text, str) else text
        self._lines = _lines(self._text)

    def set(self, text: str | Text) -> None:
        """Show ``text``; the same text again (a nudge's unchanged step lines) is not repainted,
        and of a text as many lines long only the lines that changed are."""
        new = Text.from_markup(text) if isinstance(text, str) else text
        if new is not self._text and _same(new, self._text):  # (the same object may have been changed)
            return
        lines = _lines(new)
        changed = [y for y, (a, b) in enumerate(zip(lines, self._lines)) if not _same(a, b)]
        if len(lines) != len(self._lines):
            self.refresh(layout=True)
        elif changed:
            width = max(self.size.width, 1)
            self.refresh(*(Region(0, y, width, 1) for y in changed))
        self._text, self._lines = new, lines

    @property
    def text(self) -> Text:
        """What it shows."""
        return self._text

    def render(self) -> Text:
        return self._text

    def get_content_height(self, container: Size, viewport: Size, width: int) -> int:
        return len(self._lines) if width else 0  # one row a line: it never wraps

    def render_line(self, y: int) -> Strip:
        """Line ``y`` drawn alone, by Rich (`RichVisual`: Textual's conversion of a Rich text
        to its `Content` took 5-20 ms for the tableau's changed lines); a selection, placed
        in the whole text's coordinates, is drawn by Textual's whole-text path."""
        if self.text_selection is not None:
            return super().render_line(y)
        width = self.size.width
        if not 0 <= y < len(self._lines):  # below the text (a view taller than its lines)
            return Strip.blank(width, self.visual_style.rich_style)
        line = self._lines[y]  # (an empty line as Textual draws it: the same segments as before)
        visual = RichVisual(self, line) if line.plain else visualize(self, line, markup=False)
        return Visual.to_strips(self, visual, width, 1, self.visual_style)[0]


def _lines(text: Text) -> list[Text]:
    """The text's lines (a trailing newline ends one more, empty, line)."""
    lines = list(text.split("\n", allow_blank=True))
    for line in lines:  # as the view's CSS has it (text-wrap: nowrap; text-overflow: clip)
        line.no_wrap, line.overflow = True, "crop"
    return lines


def _same(a: Text, b: Text) -> bool:
    """Whether two texts draw the same: their characters, spans and how they are laid out."""
    laid_out = ("style", "justify", "overflow", "no_wrap", "end", "tab_size")
    return a.plain == b.plain and a.spans == b.spans and all(getattr(a, k) == getattr(b, k) for k in laid_out)

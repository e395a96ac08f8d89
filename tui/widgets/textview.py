"""A text widget that repaints without a layout pass when its text changes
(unlike `Static.update`), so a run's steady updates stay cheap; its height
follows the number of lines only when that number changes; the same text set again is
not repainted, and a new text repaints only the cells it changed: each changed line
from its first changed column (Textual paints the box around every changed region of a
paint: a nudge's status line changed in its first column stretched the tableau's
paint over the plots and the tabs, some forty widgets rendered where eight had changed).
One made with ``keep_height`` shrinks after the paint of a text with fewer lines: the
tableau, whose rows come and go as a design moves (a margin found or lost), shows a nudge's
new text first and is laid out after (the layout pass of the whole screen, 2 of 14 one-way
nudges of the launch vehicle, held the tableau's paint).  One styled ``text-wrap: wrap`` (the
Sweep tab's status) wraps at its width and is laid out again on every change."""

from __future__ import annotations

from collections.abc import Iterator
from itertools import zip_longest
from os.path import commonprefix

from rich.cells import cell_len
from rich.text import Text
from textual.geometry import Region, Size
from textual.widget import Widget

LAID_OUT = ("style", "justify", "overflow", "no_wrap", "end", "tab_size")  # how a text is laid out


class TextView(Widget):
    DEFAULT_CSS = "TextView { height: auto; text-wrap: nowrap; text-overflow: clip; }"

    def __init__(self, text: str | Text = "", *, keep_height: bool = False, **kwargs):
        super().__init__(**kwargs)
        self._text = Text.from_markup(text) if isinstance(text, str) else text
        self._lines = self._text.plain.count("\n") + 1
        self.keep_height = keep_height
        self._held = 0  # lines of height held until the paint (`keep_height`)

    def set(self, text: str | Text) -> None:
        """Show ``text``; the same text again (a nudge's unchanged step lines) is not repainted."""
        new = Text.from_markup(text) if isinstance(text, str) else text
        if new is not self._text and _same(new, self._text):  # (the same object may have been changed)
            return
        old, self._text = self._text, new
        lines = new.plain.count("\n") + 1
        if self.keep_height and lines < max(self._lines, self._held):  # as tall until painted
            if not self._held:
                self.call_after_refresh(self._shrink)
            self._held = max(self._lines, self._held)
        if self.styles.text_wrap == "wrap":  # its rows on screen are not its lines: laid out again
            self.refresh(layout=True)
        elif lines > max(self._lines, self._held) or (lines != self._lines and not self.keep_height):
            self.refresh(layout=True)
        elif self.styles.text_align in ("left", "start") and _aligned_left(old) and _aligned_left(new):
            self.refresh(*(Region(x, y, max(self.size.width - x, 1), 1) for x, y in _changed_cells(old, new)))
        else:  # a column of the text is not a column on screen: all of it
            self.refresh()
        self._lines = lines

    def _shrink(self) -> None:
        """The height the text has, laid out after its paint (`keep_height`)."""
        self._held = 0
        self.refresh(layout=True)

    def get_content_height(self, container: Size, viewport: Size, width: int) -> int:
        return max(super().get_content_height(container, viewport, width), self._held)

    @property
    def text(self) -> Text:
        """What it shows."""
        return self._text

    def render(self) -> Text:
        return self._text


def _same(a: Text, b: Text) -> bool:
    """Whether two texts draw the same: their characters, spans and how they are laid out."""
    return a.plain == b.plain and a.spans == b.spans and all(getattr(a, k) == getattr(b, k) for k in LAID_OUT)


def _aligned_left(text: Text) -> bool:
    """Whether each character of ``text`` stands at its column on screen: laid out from the left,
    no tab (a changed character moves what a centred or right-aligned line shows before it)."""
    return text.justify in (None, "default", "left") and "\t" not in text.plain


def _changed_cells(old: Text, new: Text) -> Iterator[tuple[int, int]]:
    """(column, line) where each line that draws differently starts to differ: its first
    changed character, or its start when its styles changed (texts of as many lines, no
    character wider than a cell: the workbench's)."""
    if any(getattr(old, k) != getattr(new, k) for k in ("style", "justify", "overflow", "no_wrap", "tab_size")):
        yield from ((0, y) for y in range(new.plain.count("\n") + 1))
        return
    pairs = zip_longest(old.split("\n", allow_blank=True), new.split("\n", allow_blank=True))
    for y, (a, b) in enumerate(pairs):
        if a is None or b is None or a.spans != b.spans:
            yield 0, y
        elif a.plain != b.plain:
            yield cell_len(commonprefix([a.plain, b.plain])), y

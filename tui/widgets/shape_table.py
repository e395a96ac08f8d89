"""The shaping table: the plotted condition's compensators as an engineer reads them
(gain, zeros, poles, pairs, with the parameters behind each), moved by keys.  The table
only asks: each key posts a `ShapeTable.Request` (a move, a typed value, a gain solve, a
part added, a notch, a deletion) and the screen's controller (`tui.screens.shaping`)
applies it to the session as an edit (undoable, one undo step per burst on one item).
Its rows are the current design's (`MainScreen.refresh_run` fills them from the one view
every readout is drawn from).  `C` on the Run tab shows it.

It draws its own lines (Textual's line API), as Textual's `DataTable` with a row cursor
looks: one `Strip` per row kept until that row's reading, the cursor, the focus or the
width changes.  A `DataTable` dropped every row's render on any `update_cell` (its caches
are keyed by an update count): a nudge re-rendered the header and every row, 7-11 ms of
the 22-34 ms paint that shows the nudge's tableau."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from rich.padding import Padding
from rich.segment import Segment
from rich.style import Style
from textual import events
from textual.binding import Binding
from textual.geometry import Region, Size, Spacing
from textual.message import Message
from textual.reactive import reactive
from textual.renderables.styled import Styled
from textual.scroll_view import ScrollView
from textual.strip import Strip

from tui.keys import identified


class Shaped(Protocol):
    """What the table reads of a compensator's item (an `engine.design.compensator_items.Item`,
    which the screen's controller gets back in the requests): its kind."""

    @property
    def kind(self) -> str: ...


STEP, BIG_STEP = 1.05, 1.25  # frequency factors of a nudge (shift: a big one)
STEP_DB, BIG_STEP_DB = 0.5, 3.0  # the gain's nudges, dB
DAMPING_STEP = 1.1  # a pair's damping factor of a nudge
SHAPING_ACTIONS = frozenset({"nudge", "damp", "type_value", "gain_for", "add", "delete", "notch"})


COLUMNS = ("item", "reads")


class ShapeTable(ScrollView, can_focus=True):
    """One row per compensator item; left/right move it, [ and ] a pair's damping, e types
    a value, g and G solve the loop gain for a crossover or a phase margin, + adds a part,
    N a notch on a resonance and - deletes the selected item; up and down select."""

    DEFAULT_CSS = """
    ShapeTable {
        background: $surface;
        color: $foreground;
        height: auto;
        max-height: 100%;
        &:focus {
            background-tint: $foreground 5%;
            & > .shape-table--cursor {
                background: $block-cursor-background;
                color: $block-cursor-foreground;
                text-style: $block-cursor-text-style;
            }
            & > .shape-table--header { background-tint: $foreground 5%; }
        }
        & > .shape-table--header { text-style: bold; background: $panel; color: $foreground; }
        &:ansi > .shape-table--header { background: ansi_bright_blue; color: ansi_default; }
        & > .shape-table--cursor {
            background: $block-cursor-blurred-background;
            color: $block-cursor-blurred-foreground;
            text-style: $block-cursor-blurred-text-style;
        }
        & > .shape-table--header-hover { background: $accent 30%; }
        & > .shape-table--hover { background: $block-hover-background; }
    }
    """  # (`DataTable`'s, for a row cursor)
    COMPONENT_CLASSES = {
        "shape-table--header",
        "shape-table--cursor",
        "shape-table--hover",
        "shape-table--header-hover",
    }

    BINDINGS = identified(
        "shape",
        [
            Binding("up", "cursor(-1)", "", show=False, id="shape.up", tooltip="the item above"),
            Binding("down", "cursor(1)", "", show=False, id="shape.down", tooltip="the item below"),
            Binding("pageup", "page(-1)", "", show=False, id="shape.page_up", tooltip="a page of items up"),
            Binding("pagedown", "page(1)", "", show=False, id="shape.page_down", tooltip="a page of items down"),
            Binding(
                "ctrl+home", "cursor(-1000)", "", show=False, id="shape.first", tooltip="the first item (the gain)"
            ),
            Binding("ctrl+end", "cursor(1000)", "", show=False, id="shape.last", tooltip="the last item"),
            Binding("home", "across(0)", "", show=False, id="shape.left_edge", tooltip="the readings' start"),
            Binding("end", "across(1)", "", show=False, id="shape.right_edge", tooltip="the readings' end"),
            Binding(
                "left",
                "nudge(-1)",
                "lower",
                id="shape.lower",
                tooltip="the item 5 % lower in frequency (a gain 0.5 dB)",
            ),
            Binding(
                "right",
                "nudge(1)",
                "higher",
                id="shape.higher",
                tooltip="the item 5 % higher in frequency (a gain 0.5 dB)",
            ),
            Binding(
                "shift+left", "nudge(-5)", "", show=False, id="shape.lower_big", tooltip="25 % lower (a gain 3 dB)"
            ),
            Binding(
                "shift+right", "nudge(5)", "", show=False, id="shape.higher_big", tooltip="25 % higher (a gain 3 dB)"
            ),
            Binding(
                "left_square_bracket",
                "damp(-1)",
                "damping -",
                id="shape.damp_down",
                tooltip="a pair's damping 10 % lower",
            ),
            Binding(
                "right_square_bracket",
                "damp(1)",
                "damping +",
                show=False,
                id="shape.damp_up",
                tooltip="a pair's damping 10 % higher",
            ),
            Binding("e", "type_value", "set", tooltip="type the item's frequency (rad/s), or the gain"),
            Binding(
                "g", "gain_for('crossover')", "gain for wc", tooltip="the gain that puts the crossover at a frequency"
            ),
            Binding(
                "G", "gain_for('pm')", "gain for PM", tooltip="the gain that gives a phase margin (every solution)"
            ),
            Binding("plus", "add", "add", tooltip="add a lead, lag, integrator, zero, pole, notch or pole pair"),
            Binding("minus,delete", "delete", "delete", tooltip="delete the selected zero, pole or pair (its factor)"),
            Binding("N", "notch", "notch", tooltip="a notch on one of the plant's resonances (zeros on its poles)"),
        ],
    )

    class Request(Message):
        """A shaping key's request of the selected item (``name``: ``block.item``)."""

        def __init__(self, name: str, item: Shaped) -> None:
            super().__init__()
            self.name, self.item = name, item

        @property
        def block(self) -> str:
            return self.name.rsplit(".", 1)[0]

    class Move(Request):
        """Scale the item's measure (``measure``: ``block.item`` or ``block.item.zeta``) by ``scale``."""

        def __init__(self, name: str, item: Shaped, measure: str, scale: float, what: str) -> None:
            super().__init__(name, item)
            self.measure, self.scale, self.what = measure, scale, what

    class TypeValue(Request):
        """Type the item's frequency (or the gain)."""

    class GainFor(Request):
        """Solve the loop gain for ``goal``: "crossover" or "pm"."""

        def __init__(self, name: str, item: Shaped, goal: str) -> None:
            super().__init__(name, item)
            self.goal = goal

    class Add(Request):
        """Add a part to the item's compensator."""

    class Notch(Request):
        """A notch on one of the plant's resonances in the item's compensator."""

    class Delete(Request):
        """Delete the item with its factor."""

    cursor_row: reactive[int] = reactive(0, repaint=False)
    hover_row: reactive[int | None] = reactive(None, repaint=False)  # the row under the mouse (-1: the header)

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.names: list[str] = []
        self.found: list[Shaped] = []
        self.readings: list[str] = []
        self.widths = (0, 0)  # the columns' (the same rows' readings only widen them)
        self.frozen = False  # a run or a sweep goes: the screen says so (`MainScreen.refresh_status`)
        self._strips: dict[int, tuple[tuple, Strip]] = {}  # line -> (what it was drawn from, its strip)

    def fill(self, rows: Sequence[tuple[str, str, Shaped]]) -> None:
        """The items (name, reading, item), the cursor kept on its row; a row whose reading
        is unchanged keeps its strip (a nudge's, a drag's: one row drawn again; a column widened
        draws every line again); no layout pass unless the number of rows changes or a scroll
        bar comes or goes."""
        names, readings = [name for name, _, _ in rows], [text for _, text, _ in rows]
        self.found = [item for _, _, item in rows]
        if names == self.names and readings == self.readings:
            return
        before, same_rows = self.widths, names == self.names
        changed = [k for k, text in enumerate(readings) if not same_rows or text != self.readings[k]]
        self.names, self.readings = names, readings
        self.widths = _widths(names, readings, before if same_rows else (0, 0))
        size = Size(sum(self.widths), len(rows) + 1)
        if not same_rows:
            self.virtual_size = size
        elif size != self.virtual_size:  # as tall as before: a layout pass only if a scroll bar comes or goes
            self.set_reactive(ShapeTable.virtual_size, size)  # (assigned, the reactive lays the screen out)
            self._scroll_update(size)  # (Textual's own update of the scroll bars: it asks a layout pass then)
        self.cursor_row = self.cursor_row  # (validated: within the rows)
        if not same_rows:
            self.refresh(layout=True)
        elif self.widths != before:
            self.refresh()  # every line at the new widths
        else:
            for k in changed:
                self._refresh_row(k)

    def notify_style_update(self) -> None:
        """The styles changed (a theme, the CSS): every line drawn again (the strips keep the
        cursor's and the header's styles of their drawing, as `DataTable`'s caches do)."""
        super().notify_style_update()
        self._strips.clear()

    def _refresh_row(self, row: int) -> None:
        """Repaint a row where it shows (row -1: the header, which stays at the top)."""
        y = 0 if row < 0 else row + 1 - self.scroll_offset.y
        self.refresh(Region(0, y, self.outer_size.width, 1))

    @property
    def row_count(self) -> int:
        return len(self.names)

    def get_row_at(self, row: int) -> list[str]:
        """The cells of a row: the item's name and its reading."""
        return [self.names[row], self.readings[row]]

    def move_cursor(self, *, row: int) -> None:
        self.cursor_row = row

    def validate_cursor_row(self, row: int) -> int:
        return min(max(row, 0), max(len(self.names) - 1, 0))

    def watch_cursor_row(self, before: int, row: int) -> None:
        self._refresh_row(before)
        self._refresh_row(row)
        self.scroll_to_region(Region(0, row + 1, 1, 1), spacing=Spacing(top=1), animate=False, force=True)
        if self.has_focus:  # the footer shows what the newly selected item allows ([ ], delete)
            self.refresh_bindings()

    def watch_hover_row(self, before: int | None, row: int | None) -> None:
        for hovered in (before, row):
            if hovered is not None:
                self._refresh_row(hovered)

    def _on_mouse_move(self, event: events.MouseMove) -> None:
        """The row under the mouse is highlighted, as in `DataTable` (a row cursor's)."""
        row = event.style.meta.get("row")
        self.hover_row = row if isinstance(row, int) else None

    def _on_leave(self, event: events.Leave) -> None:
        self.hover_row = None

    def action_cursor(self, rows: int) -> None:
        self.hover_row = None  # (the keys move the cursor: the mouse's row is no longer shown)
        self.cursor_row += rows

    def action_page(self, pages: int) -> None:
        self.hover_row = None
        self.cursor_row += pages * max(self.scrollable_content_region.height - 1, 1)  # (under the header)

    def action_across(self, end: int) -> None:
        """Scroll to the start (0) or the end (1) of the readings, where they are wider than the table."""
        self.scroll_x = self.max_scroll_x * end

    def _on_click(self, event: events.Click) -> None:
        row = event.style.meta.get("row")
        if isinstance(row, int) and row >= 0:
            self.cursor_row = row

    def render_line(self, y: int) -> Strip:
        scroll_x, scroll_y = self.scroll_offset
        line = y if y == 0 else y + scroll_y  # (the header stays on top)
        base, width = self.rich_style, self.size.width
        row = line - 1
        drawn = (
            self._cells(line),
            self.widths,
            row == self.cursor_row,
            row == self.hover_row,
            self.has_focus,
            width,
            base,
        )
        kept = self._strips.get(line)
        if kept is None or kept[0] != drawn:
            kept = (drawn, self._line(line, base))
            self._strips[line] = kept
        return kept[1].crop(scroll_x, scroll_x + width)

    def _cells(self, line: int) -> tuple[str, ...]:
        return COLUMNS if line == 0 else tuple(self.get_row_at(line - 1)) if line <= len(self.names) else ()

    def _line(self, line: int, base: Style) -> Strip:
        """A whole line drawn as `DataTable` draws it: each cell padded by a space and styled
        (the header's style, or the cursor's over the base), then the rest of the width in the
        row's style."""
        width, cells = max(self.size.width, sum(self.widths)), self._cells(line)
        if not cells:
            return Strip.blank(width, base)
        row = line - 1
        style = self.get_component_rich_style("shape-table--header") if row < 0 else base
        cursor = Style()  # `DataTable`'s order: the mouse's row, then the cursor's
        if row == self.hover_row:
            cursor += self.get_component_rich_style("shape-table--hover")
            if row < 0:
                cursor += self.get_component_rich_style("shape-table--header-hover")
        if row == self.cursor_row:
            cursor += self.get_component_rich_style("shape-table--cursor")
        post = Style.from_color(color=cursor.color) + Style.from_color(bgcolor=cursor.bgcolor)
        options = self.app.console_options.update(no_wrap=True)
        segments: list[Segment] = []
        for column, (cell, cell_width) in enumerate(zip(cells, self.widths)):
            styled = Styled(
                Padding(cell, (0, 1)),
                pre_style=style + cursor + Style.from_meta({"row": row, "column": column}),
                post_style=post,
            )
            segments += self.app.console.render_lines(styled, options.update_dimensions(cell_width, 1))[0]
        rest = max(0, width - sum(self.widths))
        segments.append(
            Segment(" " * rest, style + cursor + Style.from_meta({"row": row, "column": 0, "out_of_bounds": True}))
        )
        return Strip(segments).adjust_cell_length(width, base).simplify()

    @property
    def selected(self) -> tuple[str, Shaped] | None:
        k = self.cursor_row
        return (self.names[k], self.found[k]) if 0 <= k < len(self.names) else None

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        return None if self.disabled_reason(action) else True

    def disabled_reason(self, action: str) -> str | None:
        """Why a shaping key cannot act now (None: it can)."""
        if action not in SHAPING_ACTIONS:
            return None
        if self.frozen:
            return "not while a run or a sweep goes (space pauses it)"
        if self.selected is None:
            return "no compensator item: the plotted loop has no tunable compensator"
        kind = self.selected[1].kind
        if action == "damp" and not kind.endswith("pair"):
            return "[ and ] move a pair's damping: select a zero pair or a pole pair"
        if action == "delete" and kind == "gain":
            return "the gain stays (a zero, a pole or a pair is deleted)"
        return None

    def _ask(self, request: type[ShapeTable.Request]) -> None:
        if self.selected is not None:
            self.post_message(request(*self.selected))

    def action_nudge(self, steps: int) -> None:
        if self.selected is None:
            return
        name, item = self.selected
        if item.kind == "gain":
            db = (STEP_DB if abs(steps) == 1 else BIG_STEP_DB) * (1 if steps > 0 else -1)
            self.post_message(self.Move(name, item, name, 10 ** (db / 20), f"{name} {db:+g} dB"))
        else:
            factor = (STEP if abs(steps) == 1 else BIG_STEP) ** (1 if steps > 0 else -1)
            self.post_message(self.Move(name, item, name, factor, f"{name} x {factor:.4g}"))

    def action_damp(self, direction: int) -> None:
        if self.selected is None:
            return
        name, item = self.selected
        scale = DAMPING_STEP**direction
        self.post_message(self.Move(name, item, f"{name}.zeta", scale, f"{name} damping x {scale:.3g}"))

    def action_type_value(self) -> None:
        self._ask(self.TypeValue)

    def action_gain_for(self, goal: str) -> None:
        if self.selected is not None:
            self.post_message(self.GainFor(*self.selected, goal))

    def action_add(self) -> None:
        self._ask(self.Add)

    def action_notch(self) -> None:
        self._ask(self.Notch)

    def action_delete(self) -> None:
        self._ask(self.Delete)


def _widths(names: list[str], readings: list[str], at_least: tuple[int, int]) -> tuple[int, int]:
    """The columns' widths: the widest cell's with a space either side, at least ``at_least``."""
    name = max([len(COLUMNS[0])] + [len(cell) for cell in names]) + 2
    reading = max([len(COLUMNS[1])] + [len(cell) for cell in readings]) + 2
    return max(name, at_least[0]), max(reading, at_least[1])

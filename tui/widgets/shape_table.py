"""The shaping table: the plotted condition's compensators as an engineer reads them
(gain, zeros, poles, pairs, with the parameters behind each), moved by keys.  The table
only asks: each key posts a `ShapeTable.Request` (a move, a typed value, a gain solve, a
part added, a notch, a deletion) and the screen's controller (`tui.screens.shaping`)
applies it to the session as an edit (undoable, one undo step per burst on one item).
Its rows are the current design's (`MainScreen.refresh_run` fills them from the one view
every readout is drawn from).  `C` on the Run tab shows it."""

from __future__ import annotations

from typing import TYPE_CHECKING

from textual.binding import Binding
from textual.coordinate import Coordinate
from textual.message import Message
from textual.widgets import DataTable

from tui.keys import identified

if TYPE_CHECKING:  # scipy behind it: never imported before the first paint
    from engine.design.compensator_items import Item

STEP, BIG_STEP = 1.05, 1.25  # frequency factors of a nudge (shift: a big one)
STEP_DB, BIG_STEP_DB = 0.5, 3.0  # the gain's nudges, dB
DAMPING_STEP = 1.1  # a pair's damping factor of a nudge
SHAPING_ACTIONS = frozenset({"nudge", "damp", "type_value", "gain_for", "add", "delete", "notch"})


class ShapeTable(DataTable):
    """One row per compensator item; left/right move it, [ and ] a pair's damping, e types
    a value, g and G solve the loop gain for a crossover or a phase margin, + adds a part,
    N a notch on a resonance and - deletes the selected item."""

    BINDINGS = identified(
        "shape",
        [
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

        def __init__(self, name: str, item: Item) -> None:
            super().__init__()
            self.name, self.item = name, item

        @property
        def block(self) -> str:
            return self.name.rsplit(".", 1)[0]

    class Move(Request):
        """Scale the item's measure (``measure``: ``block.item`` or ``block.item.zeta``) by ``scale``."""

        def __init__(self, name: str, item: Item, measure: str, scale: float, what: str) -> None:
            super().__init__(name, item)
            self.measure, self.scale, self.what = measure, scale, what

    class TypeValue(Request):
        """Type the item's frequency (or the gain)."""

    class GainFor(Request):
        """Solve the loop gain for ``goal``: "crossover" or "pm"."""

        def __init__(self, name: str, item: Item, goal: str) -> None:
            super().__init__(name, item)
            self.goal = goal

    class Add(Request):
        """Add a part to the item's compensator."""

    class Notch(Request):
        """A notch on one of the plant's resonances in the item's compensator."""

    class Delete(Request):
        """Delete the item with its factor."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(cursor_type="row", id=id)
        self.names: list[str] = []
        self.found: list[Item] = []
        self.frozen = False  # a run or a sweep goes: the screen says so (`MainScreen.refresh_status`)

    def fill(self, rows: list[tuple[str, str, Item]]) -> None:
        """The items (name, reading, item), the cursor kept on its row; the items shown
        already (a nudge's, a drag's) have their readings changed in place (no rows made
        anew, no cursor moved: the keys' footer is not rebuilt, the screen not laid out)."""
        names = [name for name, _, _ in rows]
        if self.columns and names == self.names and self.row_count == len(rows):
            self.found = [item for _, _, item in rows]
            width = self.ordered_columns[1].content_width
            for k, (_, text, _) in enumerate(rows):
                if self.get_cell_at(Coordinate(k, 1)) != text:  # the column widened only for a longer reading
                    self.update_cell_at(Coordinate(k, 1), text, update_width=len(text) > width)
            return
        row = self.cursor_row
        self.clear(columns=not self.columns)
        if not self.columns:
            self.add_columns("item", "reads")
        self.names = [name for name, _, _ in rows]
        self.found = [item for _, _, item in rows]
        for name, text, _ in rows:
            self.add_row(name, text)
        if rows:
            self.move_cursor(row=min(max(row, 0), len(rows) - 1))

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        if self.has_focus:  # the footer shows what the newly selected item allows ([ ], delete)
            self.refresh_bindings()

    @property
    def selected(self) -> tuple[str, Item] | None:
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

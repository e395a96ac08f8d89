"""The workbench's editable tables, each a widget with its own keys.

Every row carries a `Ref` (the path of the model object it shows), so an
action acts on that object whatever the layout.  A table only asks: each key
posts a `RefTable.Request` (the action and the selected row's reference) and
the screen's controller (`tui.screens.table_edits`) applies it to the session
through `EditFlow`.  Keys that change the problem are disabled (dimmed in the
footer) while a run or a sweep goes (``frozen``, set by the screen), and keys
that do not apply to the selected row are disabled too (``allows``, the
controller's answer for what depends on the session).
"""

from __future__ import annotations

from collections.abc import Callable

from textual.binding import Binding
from textual.message import Message
from textual.widgets import DataTable

from tui.keys import identified
from tui.state.edits import Ref


class RefTable(DataTable):
    """A DataTable whose rows carry model references; its keys post `Request`s."""

    KIND = ""  # what the controller calls the table's requests: "plant", "parameters", ...
    MUTATING: frozenset[str] = frozenset()
    DELETES = "row"  # what `-` deletes, in its question

    class Request(Message):
        """A key's ``action`` on the selected row (``ref``; empty: no row) of ``table``."""

        def __init__(self, table: RefTable, action: str, ref: Ref) -> None:
            super().__init__()
            self.table, self.action, self.ref = table, action, ref

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(cursor_type="row", id=id)
        self.refs: list[Ref | None] = []
        self.pending: Ref | None = None  # the row to select at the next fill (a row just added)
        self.frozen = False  # a run or a sweep goes (the screen says so)
        # whether an action can act on a row, where that depends on the session (the controller's)
        self.allows: Callable[[RefTable, str, Ref], bool] = lambda table, action, ref: True

    def fill(self, columns: tuple[str, ...], rows: list[tuple[tuple, Ref | None]]) -> None:
        """Replace the table's rows (each: its cells and its reference), keeping the cursor row."""
        row = self.cursor_row
        self.clear(columns=True)
        self.add_columns(*columns)
        self.refs = []
        for cells, ref in rows:
            self.add_row(*cells)
            self.refs.append(ref)
        if self.pending in self.refs:
            row, self.pending = self.refs.index(self.pending), None
        if rows:
            self.move_cursor(row=min(max(row, 0), len(rows) - 1))

    @property
    def ref(self) -> Ref | None:
        """The selected row's reference."""
        k = self.cursor_row
        return self.refs[k] if 0 <= k < len(self.refs) else None

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action in self.MUTATING or action == "select_cursor":
            return None if self.frozen or not self.applies(action) else True
        return True

    def applies(self, action: str) -> bool:
        """Whether an action can act on the selected row."""
        ref = self.ref
        return ref is not None and self.allows(self, action, ref)

    def ask(self, action: str) -> None:
        """Post the request of a key (the controller applies it)."""
        self.post_message(self.Request(self, action, self.ref or ()))

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        if self.has_focus:  # the footer shows what the newly selected row allows
            self.refresh_bindings()

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        """enter edits the row, where the table edits rows."""
        event.stop()
        if "edit" in self.MUTATING and not self.frozen and self.applies("edit"):
            self.ask("edit")

    def action_edit(self) -> None:
        self.ask("edit")

    def action_add(self) -> None:
        self.ask("add")

    def action_delete(self) -> None:
        """Delete the selected model object (always asks first)."""
        self.ask("delete")


class PlantTable(RefTable):
    """Blocks, junctions, matrix entries and break points of every condition."""

    BINDINGS = identified(
        "plant",
        [
            Binding("e", "edit", "edit"),
            Binding("plus", "add", "add block"),
            Binding("minus,delete", "delete", "delete"),
            Binding("c", "copy_condition", "copy condition", show=False),
            Binding("x", "delete_condition", "delete condition", show=False),
            Binding("i", "import_table", "import CSV", show=False),
        ],
    )
    KIND = "plant"
    MUTATING = frozenset({"edit", "add", "delete", "copy_condition", "delete_condition", "import_table"})

    def applies(self, action: str) -> bool:
        ref = self.ref
        if ref is None:
            return False
        if action == "delete":
            return isinstance(ref[-1], int) and ref[-2] in ("blocks", "entries")
        if action == "import_table":
            return isinstance(ref[-1], int) and ref[-2] == "blocks"
        return self.allows(self, action, ref)

    def action_copy_condition(self) -> None:
        self.ask("copy_condition")

    def action_delete_condition(self) -> None:
        self.ask("delete_condition")

    def action_import_table(self) -> None:
        self.ask("import_table")


class ParametersTable(RefTable):
    """The parameters: value, bounds, free or fixed, shared or per condition."""

    BINDINGS = identified(
        "parameters",
        [
            Binding("e", "edit", "edit"),
            Binding("f", "toggle_free", "free", tooltip="free or fix the parameter"),
            Binding("g", "toggle_per_condition", "shared/per condition", show=False),
            Binding("plus", "add", "add"),
            Binding("minus,delete", "delete", "delete"),
        ],
    )
    KIND = "parameters"
    MUTATING = frozenset({"edit", "toggle_free", "toggle_per_condition", "add", "delete"})
    DELETES = "parameter"

    def applies(self, action: str) -> bool:
        return action == "add" or self.ref is not None

    def action_toggle_free(self) -> None:
        self.ask("toggle_free")

    def action_toggle_per_condition(self) -> None:
        self.ask("toggle_per_condition")


class TargetsTable(RefTable):
    """The targets: bands, points, weights, detection ranges, time responses."""

    BINDINGS = identified(
        "targets",
        [Binding("e", "edit", "edit"), Binding("plus", "add", "add"), Binding("minus,delete", "delete", "delete")],
    )
    KIND = "targets"
    MUTATING = frozenset({"edit", "add", "delete"})
    DELETES = "target"

    def applies(self, action: str) -> bool:
        return action == "add" or self.ref is not None


class SettingsTable(RefTable):
    """The objective's options and the algorithm's settings."""

    BINDINGS = identified(
        "settings",
        [
            Binding("e", "edit", "edit"),
            Binding("plus", "add", "add constraint", tooltip="a linear constraint between parameters, e.g. T1 >= 4*T2"),
            Binding("minus,delete", "delete", "delete constraint"),
        ],
    )
    KIND = "settings"
    MUTATING = frozenset({"edit", "add", "delete"})
    DELETES = "constraint"

    def applies(self, action: str) -> bool:
        if action == "add":
            return True
        if action == "delete":
            return self.ref is not None and self.ref[0] == "constraint"
        return self.ref is not None


class HistoryTable(RefTable):
    """One row per iteration; enter makes the selected one the current iteration, after asking
    (the History pane around it marks one and chooses the plot's view).  Not b: that is the app's
    break key, which draws the History plot at the next loop break from this table too."""

    BINDINGS = identified(
        "history",
        [Binding("enter", "start_here", "start here", tooltip="start again from the selected iteration (asks first)")],
    )
    KIND = "history"
    MUTATING = frozenset({"start_here"})

    def action_start_here(self) -> None:
        self.ask("start_here")

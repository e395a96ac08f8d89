"""The workbench's editable tables, each a widget with its own keys.

Every row carries a `Ref` (the path of the model object it shows), so an
action acts on that object whatever the layout.  Keys that change the
problem are disabled (dimmed in the footer) while a run or a sweep goes,
and keys that do not apply to the selected row are disabled too; the app's
`busy` says which.  The dialogs and the transaction are `EditFlow`'s.
"""

from __future__ import annotations

from pathlib import Path

from textual.binding import Binding
from textual.widgets import DataTable

from engine.design.measure_kinds import MEASURE_KINDS
from sessions.lifecycle import folder
from tui.files import file_problem
from tui.keys import identified
from tui.state import edits
from tui.state import field_edits as edits_fields
from tui.state.edits import Ref


class RefTable(DataTable):
    """A DataTable whose rows carry model references."""

    MUTATING: frozenset[str] = frozenset()
    DELETES = "row"  # what `-` deletes, in its question

    def __init__(self, **kwargs):
        super().__init__(cursor_type="row", **kwargs)
        self.refs: list[Ref | None] = []
        self.pending: Ref | None = None  # the row to select at the next fill (a row just added)

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

    @property
    def flow(self):
        return self.app.edit_flow

    @property
    def bench(self):
        return self.app.bench

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action in self.MUTATING or action == "select_cursor":
            return None if self.app.busy or not self.applies(action) else True
        return True

    def applies(self, action: str) -> bool:
        """Whether an action can act on the selected row."""
        return self.ref is not None

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        if self.has_focus:  # the footer shows what the newly selected row allows
            self.refresh_bindings()

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        """enter edits the row, where the table edits rows."""
        event.stop()
        if "edit" in self.MUTATING and not self.app.busy and self.applies("edit"):
            self.action_edit()

    def action_delete(self) -> None:
        """Delete the selected model object (always asks first)."""
        ref = self.ref
        self.flow.change(
            lambda: edits.delete_item(self.bench, ref),
            f"delete the selected {self.DELETES}",
            always_ask=True,
            done=lambda what: self.app.notify(f"deleted {what}"),
        )


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
    MUTATING = frozenset({"edit", "add", "delete", "copy_condition", "delete_condition", "import_table"})

    def applies(self, action: str) -> bool:
        ref = self.ref
        if ref is None:
            return False
        if action == "edit":
            return edits.plant_edit(self.bench, ref) is not None
        if action == "delete":
            return isinstance(ref[-1], int) and ref[-2] in ("blocks", "entries")
        if action == "import_table":
            return isinstance(ref[-1], int) and ref[-2] == "blocks"
        if action == "delete_condition":
            return len(self.bench.session.model.problem.conditions) > 1
        return True

    def action_edit(self) -> None:
        self.flow.open(edits.plant_edit(self.bench, self.ref))

    def action_add(self) -> None:
        ref = self.ref
        self.flow.line(
            "new block: NAME INPUT OUTPUT EXPRESSION, or matrix entry: ROW COL EXPRESSION",
            edits.add_check(self.bench, ref),
            lambda text: edits.add_to_plant(self.bench, ref, text),
            "add it",
        )

    def action_copy_condition(self) -> None:
        ref = self.ref
        self.flow.line(
            "copy this condition as (a new name):",
            lambda t: None if t.strip() else "a name",
            lambda name: edits.copy_condition(self.bench, ref, name),
            "add a condition",
        )

    def action_delete_condition(self) -> None:
        ref = self.ref
        self.flow.change(
            lambda: edits.delete_condition(self.bench, ref),
            "delete the selected row's condition",
            always_ask=True,
            done=lambda name: self.app.notify(f"deleted condition {name}"),
        )

    def action_import_table(self) -> None:
        ref, base = self.ref, folder(self.bench.session)

        def chosen(text: str) -> None:
            path = Path(text).expanduser()
            path = path if path.is_absolute() else base / path
            try:
                edit = edits_fields.table_import(self.bench, ref, path)
            except (OSError, ValueError) as exc:
                self.app.notify(str(exc), title="cannot read the table", severity="error")
                return
            self.flow.open(edit)

        from tui.screens.dialogs import EditDialog

        self.app.push_screen(
            EditDialog(
                "CSV file (relative to the session's folder)",
                "",
                lambda t: file_problem(base / Path(t).expanduser()),
            ),
            lambda text: text and chosen(text),
        )


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
    MUTATING = frozenset({"edit", "toggle_free", "toggle_per_condition", "add", "delete"})
    DELETES = "parameter"

    def applies(self, action: str) -> bool:
        return action == "add" or self.ref is not None

    def action_edit(self) -> None:
        ref = self.ref
        self.flow.choose(
            "edit which field of the parameter?",
            edits_fields.PARAMETER_FIELDS,
            lambda field: self.flow.open(edits_fields.parameter_edit(self.bench, ref, field)),
        )

    def action_toggle_free(self) -> None:
        ref = self.ref
        self.flow.change(lambda: edits_fields.toggle_free(self.bench, ref), "free/fix the parameter")

    def action_toggle_per_condition(self) -> None:
        ref = self.ref
        self.flow.change(lambda: edits_fields.toggle_per_condition(self.bench, ref), "switch shared/per condition")

    def action_add(self) -> None:
        """A new parameter, selected once added (f then frees or fixes it, not another one)."""

        def add(text: str) -> None:
            edits_fields.add_parameter(self.bench, text)
            self.pending = ("parameters", len(self.bench.session.model.problem.parameters) - 1)

        self.flow.line("new parameter: NAME VALUE [MIN MAX]", edits_fields.ADD_PARAMETER_CHECK, add, "add it")


class TargetsTable(RefTable):
    """The targets: bands, points, weights, detection ranges, time responses."""

    BINDINGS = identified(
        "targets",
        [Binding("e", "edit", "edit"), Binding("plus", "add", "add"), Binding("minus,delete", "delete", "delete")],
    )
    MUTATING = frozenset({"edit", "add", "delete"})
    DELETES = "target"

    def applies(self, action: str) -> bool:
        return action == "add" or self.ref is not None

    def action_edit(self) -> None:
        ref = self.ref
        self.flow.choose(
            "edit which part of the target?",
            edits_fields.TARGET_FIELDS,
            lambda field: self.flow.open(edits_fields.target_edit(self.bench, ref, field)),
        )

    def action_add(self) -> None:
        choices = [(name, f"default desired {kind.default_desired:g}") for name, kind in MEASURE_KINDS.items()]
        self.flow.choose(
            "add a target: which measure?",
            choices,
            lambda m: self.flow.change(lambda: edits_fields.add_target(self.bench, m), f"add {m}"),
        )


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
    MUTATING = frozenset({"edit", "add", "delete"})
    DELETES = "constraint"

    def applies(self, action: str) -> bool:
        if action == "add":
            return True
        if action == "delete":
            return self.ref is not None and self.ref[0] == "constraint"
        return self.ref is not None

    def action_add(self) -> None:
        self.flow.line(
            "new constraint: a1*p1 + a2*p2 ... <= c (or >=), e.g. T1 >= 4*T2",
            edits_fields.constraint_check(self.bench, None),
            lambda text: edits_fields.add_constraint(self.bench, text),
            "add the constraint",
        )

    def action_delete(self) -> None:
        index = self.ref[1]
        self.flow.change(
            lambda: edits.change_list(self.bench, ("constraints",), lambda items: items.pop(index)),
            "delete the selected constraint",
            always_ask=True,
            done=lambda _: self.app.notify(f"deleted constraint {index + 1}"),
        )

    def action_edit(self) -> None:
        self.flow.open(edits_fields.objective_edit(self.bench, self.ref))


class HistoryTable(RefTable):
    """One row per iteration; b makes the selected one the current iteration (the
    History pane around it marks one and chooses the plot's view)."""

    BINDINGS = identified("history", [Binding("b", "start_here", "start here")])
    MUTATING = frozenset({"start_here"})

    def applies(self, action: str) -> bool:
        return self.ref is not None and self.ref[0] < self.bench.iteration

    def action_start_here(self) -> None:
        iteration = self.ref[0]
        self.flow.change(
            lambda: self.bench.start_from(iteration),
            f"make iteration {iteration} the current one (later iterations are dropped)",
            always_ask=True,
            keeps_design=False,
            done=lambda _: self.app.notify(f"iteration {iteration} is the current one"),
        )

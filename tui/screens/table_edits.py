"""The workbench tables' requests applied to the session (`RefTable.Request`,
`MatrixTable.EditCell`): the tables only ask, this part of the main screen
(``screen.table_edits``) opens the dialogs and makes the edits through `EditFlow`,
and answers what a table's keys can act on where that depends on the session
(`allows`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, cast

from engine.design.measure_kinds import MEASURE_KINDS
from sessions.forms import one_line as forms
from sessions.lifecycle import folder
from tui.files import file_problem
from tui.screens.dialogs import EditDialog
from tui.state import edits
from tui.state import field_edits as edits_fields
from tui.state.edits import Edit, Ref
from tui.widgets.matrix_table import MatrixTable
from tui.widgets.tables import RefTable

if TYPE_CHECKING:
    from tui.app import LoopcraftApp
    from tui.screens.edit_flow import EditFlow
    from tui.screens.main import MainScreen
    from tui.state.workbench import Workbench


class TableEdits:
    """Applies the tables' requests: ``KIND_action`` methods (``plant_edit``), else the
    action shared by every table (``delete``)."""

    def __init__(self, screen: MainScreen) -> None:
        self.screen = screen

    @property
    def app(self) -> LoopcraftApp:
        return cast("LoopcraftApp", self.screen.app)

    @property
    def bench(self) -> Workbench:
        return self.screen.bench

    @property
    def flow(self) -> EditFlow:
        return self.app.edit_flow

    def allows(self, table: RefTable, action: str, ref: Ref) -> bool:
        """Whether a table's key can act on a row, where that depends on the session."""
        if table.KIND == "plant" and action == "edit":
            return edits.plant_edit(self.bench, ref) is not None
        if table.KIND == "plant" and action == "delete_condition":
            return len(self.bench.session.model.problem.conditions) > 1
        if table.KIND == "history":
            return ref[0] < self.bench.iteration
        return True

    def handle(self, request: RefTable.Request) -> None:
        """Carry out a table's request (the app may have become busy since it was posted)."""
        if self.app.busy:
            self.app.notify("not while a run or a sweep goes (space pauses it)", timeout=3)
            return
        method = getattr(self, f"{request.table.KIND}_{request.action}", None)
        shared = getattr(self, request.action, None)
        act = cast("Callable[[RefTable.Request], None] | None", method or shared)
        if act is not None:
            act(request)

    def delete(self, request: RefTable.Request) -> None:
        """Delete the selected model object (always asks first)."""
        bench, ref = self.bench, request.ref
        self.flow.change(
            lambda: edits.delete_item(bench, ref),
            f"delete the selected {request.table.DELETES}",
            always_ask=True,
            done=lambda what: self.app.notify(f"deleted {what}"),
        )

    # -- the plant table -----------------------------------------------------

    def plant_edit(self, request: RefTable.Request) -> None:
        self.flow.open(edits.plant_edit(self.bench, request.ref))

    def plant_add(self, request: RefTable.Request) -> None:
        bench, ref = self.bench, request.ref
        self.flow.line(
            "new block: NAME INPUT OUTPUT EXPRESSION, or matrix entry: ROW COL EXPRESSION",
            edits.add_check(bench, ref),
            lambda text: edits.add_to_plant(bench, ref, text),
            "add it",
        )

    def plant_copy_condition(self, request: RefTable.Request) -> None:
        bench, ref = self.bench, request.ref
        self.flow.line(
            "copy this condition as (a new name):",
            lambda t: None if t.strip() else "a name",
            lambda name: edits.copy_condition(bench, ref, name),
            "add a condition",
        )

    def plant_delete_condition(self, request: RefTable.Request) -> None:
        bench, ref = self.bench, request.ref
        self.flow.change(
            lambda: edits.delete_condition(bench, ref),
            "delete the selected row's condition",
            always_ask=True,
            done=lambda name: self.app.notify(f"deleted condition {name}"),
        )

    def plant_import_table(self, request: RefTable.Request) -> None:
        bench, ref, base = self.bench, request.ref, folder(self.bench.session)

        def chosen(text: str) -> None:
            path = Path(text).expanduser()
            path = path if path.is_absolute() else base / path
            try:
                edit = edits_fields.table_import(bench, ref, path)
            except (OSError, ValueError) as exc:
                self.app.notify(str(exc), title="cannot read the table", severity="error")
                return
            self.flow.open(edit)

        def typed(text: str | None) -> None:
            if text:
                chosen(text)

        self.app.push_screen(
            EditDialog(
                "CSV file (relative to the session's folder)", "", lambda t: file_problem(base / Path(t).expanduser())
            ),
            typed,
        )

    def matrix_cell(self, message: MatrixTable.EditCell) -> None:
        """e on the matrix grid: the cell's entry edited, or a new entry in an empty cell."""
        if self.app.busy:
            return
        bench, base = self.bench, ("conditions", message.condition, "plant", "entries")
        if message.index is not None:
            self.flow.open(edits.plant_edit(bench, base + (message.index,)))
            return
        variable = bench.session.model.problem.conditions[message.condition].variable
        row, col = message.row, message.col

        def check(text: str) -> str | None:
            try:
                forms.parse_expression(text, variable)
            except ValueError as exc:
                return str(exc)
            return None

        self.flow.open(
            Edit(
                f"new entry a[{row + 1},{col}] (expression in {variable})",
                "",
                check,
                lambda text: edits.add_to_plant(bench, base[:-1] + ("entries", 0), f"{row + 1} {col} {text}"),
            )
        )

    # -- parameters, targets, settings, history ------------------------------------

    def parameters_edit(self, request: RefTable.Request) -> None:
        bench, ref = self.bench, request.ref
        self.flow.choose(
            "edit which field of the parameter?",
            edits_fields.PARAMETER_FIELDS,
            lambda field: self.flow.open(edits_fields.parameter_edit(bench, ref, field)),
        )

    def parameters_toggle_free(self, request: RefTable.Request) -> None:
        bench, ref = self.bench, request.ref
        self.flow.change(lambda: edits_fields.toggle_free(bench, ref), "free/fix the parameter")

    def parameters_toggle_per_condition(self, request: RefTable.Request) -> None:
        bench, ref = self.bench, request.ref
        self.flow.change(lambda: edits_fields.toggle_per_condition(bench, ref), "switch shared/per condition")

    def parameters_add(self, request: RefTable.Request) -> None:
        """A new parameter, selected once added (f then frees or fixes it, not another one)."""
        bench, table = self.bench, request.table

        def add(text: str) -> None:
            edits_fields.add_parameter(bench, text)
            table.pending = ("parameters", len(bench.session.model.problem.parameters) - 1)

        self.flow.line("new parameter: NAME VALUE [MIN MAX]", edits_fields.ADD_PARAMETER_CHECK, add, "add it")

    def targets_edit(self, request: RefTable.Request) -> None:
        bench, ref = self.bench, request.ref
        self.flow.choose(
            "edit which part of the target?",
            edits_fields.TARGET_FIELDS,
            lambda field: self.flow.open(edits_fields.target_edit(bench, ref, field)),
        )

    def targets_add(self, request: RefTable.Request) -> None:
        bench = self.bench
        choices = [(name, f"default desired {kind.default_desired:g}") for name, kind in MEASURE_KINDS.items()]
        self.flow.choose(
            "add a target: which measure?",
            choices,
            lambda m: self.flow.change(lambda: edits_fields.add_target(bench, m), f"add {m}"),
        )

    def settings_add(self, request: RefTable.Request) -> None:
        bench = self.bench
        self.flow.line(
            "new constraint: a1*p1 + a2*p2 ... <= c (or >=), e.g. T1 >= 4*T2",
            edits_fields.constraint_check(bench, None),
            lambda text: edits_fields.add_constraint(bench, text),
            "add the constraint",
        )

    def settings_delete(self, request: RefTable.Request) -> None:
        bench, index = self.bench, request.ref[1]
        self.flow.change(
            lambda: edits.change_list(bench, ("constraints",), lambda items: items.pop(index)),
            "delete the selected constraint",
            always_ask=True,
            done=lambda _: self.app.notify(f"deleted constraint {index + 1}"),
        )

    def settings_edit(self, request: RefTable.Request) -> None:
        self.flow.open(edits_fields.objective_edit(self.bench, request.ref))

    def history_start_here(self, request: RefTable.Request) -> None:
        bench, iteration = self.bench, request.ref[0]
        self.flow.change(
            lambda: bench.start_from(iteration),
            f"make iteration {iteration} the current one (later iterations are dropped)",
            always_ask=True,
            keeps_design=False,
            done=lambda _: self.app.notify(f"iteration {iteration} is the current one"),
        )

"""The Plant tab's grid of a matrix-format plant (`tui.state.matrix_grid`): one row
per equation, one column per signal and the forcing; e edits the selected
cell's entry in place (an empty cell gets a new entry)."""

from __future__ import annotations

from textual.binding import Binding
from textual.widgets import DataTable

from sessions.forms import one_line as forms
from tui.keys import identified
from tui.state import edits
from tui.state.edits import Edit
from tui.state.matrix_grid import matrix_grid


class MatrixTable(DataTable):
    """The grid of the first matrix-format condition (the plotted one when it is one)."""

    BINDINGS = identified(
        "matrix",
        [Binding("e", "edit_cell", "edit entry", tooltip="edit the selected entry of A(s) (an empty cell adds one)")],
    )

    def __init__(self, **kwargs):
        super().__init__(cursor_type="cell", **kwargs)
        self.condition: int | None = None
        self.cells: list[list[int | None]] = []

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "edit_cell":
            return None if self.app.busy or self.condition is None or not self._in_matrix() else True
        return True

    def _in_matrix(self) -> bool:
        row, col = self.cursor_coordinate
        return 0 <= row < len(self.cells) and 0 <= col - 1 < len(self.cells[row]) - 1

    def fill(self, problem_model, plotted: int | None) -> None:
        """Show the grid of a matrix-format condition; hidden when there is none."""
        matrix = [k for k, c in enumerate(problem_model.conditions) if c.plant.format == "matrix"]
        self.condition = (plotted if plotted in matrix else matrix[0]) if matrix else None
        self.display = self.condition is not None
        if self.condition is None:
            return
        cursor = self.cursor_coordinate
        headers, rows = matrix_grid(problem_model.conditions[self.condition].plant)
        self.clear(columns=True)
        self.add_columns(f"{problem_model.conditions[self.condition].name}: row", *headers)
        self.cells = []
        for label, cells in rows:
            self.add_row(label, *[text for text, _ in cells])
            self.cells.append([index for _, index in cells])
        self.move_cursor(row=min(cursor.row, len(rows) - 1), column=cursor.column)

    def action_edit_cell(self) -> None:
        row, col = self.cursor_coordinate
        index = self.cells[row][col - 1]
        bench, k = self.app.bench, self.condition
        base = ("conditions", k, "plant", "entries")
        if index is not None:
            self.app.edit_flow.open(edits.plant_edit(bench, base + (index,)))
            return
        variable = bench.session.model.problem.conditions[k].variable

        def check(text: str) -> str | None:
            try:
                forms.parse_expression(text, variable)
            except ValueError as exc:
                return str(exc)
            return None

        self.app.edit_flow.open(
            Edit(
                f"new entry a[{row + 1},{col}] (expression in {variable})",
                "",
                check,
                lambda text: edits.add_to_plant(bench, base[:-1] + ("entries", 0), f"{row + 1} {col} {text}"),
            )
        )

"""The Plant tab's grid of a matrix-format plant (`tui.state.matrix_grid`): one row
per equation, one column per signal and the forcing; e edits the selected
cell's entry in place (an empty cell gets a new entry): the grid posts
`MatrixTable.EditCell` and the screen's controller (`tui.screens.table_edits`) edits."""

from __future__ import annotations

from textual.binding import Binding
from textual.message import Message
from textual.widgets import DataTable

from tui.keys import identified
from tui.state.matrix_grid import Shown


class MatrixTable(DataTable):
    """The grid of the first matrix-format condition (the plotted one when it is one)."""

    BINDINGS = identified(
        "matrix",
        [Binding("e", "edit_cell", "edit entry", tooltip="edit the selected entry of A(s) (an empty cell adds one)")],
    )

    class EditCell(Message):
        """e on a cell: row ``row`` (0-based) and column ``col`` (1-based: 0 is the row's
        label) of ``condition``'s matrix; ``index``: its entry's, None for an empty cell."""

        def __init__(self, condition: int, row: int, col: int, index: int | None) -> None:
            super().__init__()
            self.condition, self.row, self.col, self.index = condition, row, col, index

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(cursor_type="cell", id=id)
        self.condition: int | None = None
        self.cells: list[list[int | None]] = []
        self.frozen = False  # a run or a sweep goes (the screen says so)

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action == "edit_cell":
            return None if self.frozen or self.condition is None or not self._in_matrix() else True
        return True

    def _in_matrix(self) -> bool:
        row, col = self.cursor_coordinate
        return 0 <= row < len(self.cells) and 0 <= col - 1 < len(self.cells[row]) - 1

    def fill(self, grid: Shown | None) -> None:
        """Show a matrix-format condition's grid (`tui.state.matrix_grid.shown_grid`); hidden
        when there is none."""
        self.condition = None if grid is None else grid[0]
        self.display = grid is not None
        if grid is None:
            return
        cursor = self.cursor_coordinate
        _, name, headers, rows = grid
        self.clear(columns=True)
        self.add_columns(f"{name}: row", *headers)
        self.cells = []
        for label, cells in rows:
            self.add_row(label, *[text for text, _ in cells])
            self.cells.append([index for _, index in cells])
        self.move_cursor(row=min(cursor.row, len(rows) - 1), column=cursor.column)

    def action_edit_cell(self) -> None:
        row, col = self.cursor_coordinate
        if self.condition is not None and self._in_matrix():
            self.post_message(self.EditCell(self.condition, row, col, self.cells[row][col - 1]))

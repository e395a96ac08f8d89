"""The Plant tab's grid of a matrix-format plant: COEBRA's A(s) x = B theta
(report 003, Appendix D) with one row per equation and one column per signal,
plus the forcing column B.  Pure data (no Textual): each cell says which of the
plant's entries it shows, so the tab can edit that entry in place."""

from __future__ import annotations

from sessions.format.schema import MatrixModel, ProblemModel

Cell = tuple[str, int | None]  # (the text shown, the index in plant.entries or None)
GridRow = tuple[str, list[Cell]]  # (the row's label, one cell per column)
Shown = tuple[int, str, list[str], list[GridRow]]  # a condition's index and name, the grid's headers and rows


def shown_grid(problem: ProblemModel, plotted: int | None) -> Shown | None:
    """The grid the Plant tab shows: of the plotted condition when its plant is a matrix,
    else of the first matrix-format condition (None: no condition has one)."""
    matrix = [k for k, c in enumerate(problem.conditions) if c.plant.format == "matrix"]
    if not matrix:
        return None
    k = plotted if plotted in matrix else matrix[0]
    condition = problem.conditions[k]
    assert isinstance(condition.plant, MatrixModel)
    return (k, condition.name, *matrix_grid(condition.plant))


def matrix_grid(plant: MatrixModel) -> tuple[list[str], list[GridRow]]:
    """Column headers (the signals, then 'forcing') and one row per equation, labelled
    'i signal' (row i defines signal i).  A cell is the entry's expression and its index
    in ``plant.entries``, or ('', None) where the entry is zero (absent); the forcing
    column shows ``forcing`` in the forcing row (index None: it is not an entry).
    Where a cell is given twice the last entry counts, as in the build; an entry
    outside the n x n matrix (which the build refuses) has no cell."""
    n = len(plant.signals)
    at: dict[tuple[int, int], int] = {}
    for k, entry in enumerate(plant.entries):
        if entry.row <= n and entry.col <= n:
            at[(entry.row, entry.col)] = k
    rows: list[GridRow] = []
    for i, signal in enumerate(plant.signals, start=1):
        cells: list[Cell] = []
        for j in range(1, n + 1):
            k = at.get((i, j))
            cells.append(("", None) if k is None else (plant.entries[k].expression, k))
        cells.append((plant.forcing if i == plant.forcing_row else "", None))
        rows.append((f"{i} {signal}", cells))
    return list(plant.signals) + ["forcing"], rows

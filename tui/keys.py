"""Every key binding has an id (``app.step``, ``plant.edit``, ...), so the user's
config can rebind it (Textual keymaps, `tui.config`)."""

from __future__ import annotations

import re
from dataclasses import replace

from textual.binding import Binding


def identified(prefix: str, bindings: list[Binding]) -> list[Binding]:
    """The bindings, each with the id ``prefix.action`` (``tab('run')`` -> ``tab_run``)."""
    return [replace(b, id=b.id or f"{prefix}.{_name(b.action)}") for b in bindings]


def _name(action: str) -> str:
    return re.sub(r"\W+", "_", action).strip("_")


def binding_table() -> list[tuple[str, str, str]]:
    """(id, keys, what it does) of every binding of the app, the workbench and its tables."""
    from tui.app import LoopcraftApp
    from tui.screens.history_pane import HistoryPane
    from tui.screens.main import MainScreen
    from tui.widgets.plots import FigurePlot
    from tui.widgets.tables import HistoryTable, ParametersTable, PlantTable, SettingsTable, TargetsTable

    rows = []
    for owner in (
        LoopcraftApp,
        MainScreen,
        PlantTable,
        ParametersTable,
        TargetsTable,
        SettingsTable,
        HistoryTable,
        HistoryPane,
        FigurePlot,
    ):
        rows += [(b.id, b.key, b.tooltip or b.description) for b in owner.BINDINGS]
    return rows

"""Every key binding has an id (``app.step``, ``plant.edit``, ...), so the user's
config can rebind it (Textual keymaps, `tui.config`)."""

from __future__ import annotations

import re
from dataclasses import replace

from textual.binding import Binding

_IDENTIFIED: list[Binding] = []  # every binding made by `identified`, in the order the classes were defined


def identified(prefix: str, bindings: list[Binding]) -> list[Binding]:
    """The bindings, each with the id ``prefix.action`` (``tab('run')`` -> ``tab_run``),
    kept for `binding_table`."""
    named = [replace(b, id=b.id or f"{prefix}.{_name(b.action)}") for b in bindings]
    _IDENTIFIED.extend(named)
    return named


def _name(action: str) -> str:
    return re.sub(r"\W+", "_", action).strip("_")


def binding_table() -> list[tuple[str, str, str]]:
    """(id, keys, what it does) of every binding made by `identified` so far: the app's,
    the workbench's, its tables' and plots' once `tui.app` is imported (this module
    imports no widget: every widget imports it)."""
    return [(b.id or "", b.key, b.tooltip or b.description) for b in _IDENTIFIED]

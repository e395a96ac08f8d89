"""The new-session dialogs: which kind of session, then the plant and the
compensator's structure (`sessions.new.templates`, `sessions.new.template_kinds`).

A unity-feedback design from nothing is: ctrl+n (n on the start screen),
enter, the plant expression, enter, the structure (down to lead), enter.
The session starts with PM >= 45 deg and GM >= 6 dB and the slp algorithm
(`a` chooses another), in the config's frequency unit."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sessions.build import read_csv
from sessions.errors import SessionError
from sessions.forms.one_line import parse_sample_time
from sessions.new import template_kinds, templates
from tui.screens.dialogs import ChooseDialog, EditDialog
from tui.state.field_edits import csv_preview, guessed_table_line, table_transfer

PLANT_HINT = "an expression in s (or w), e.g. 10/(s*(s+1)*(s+5)); exp(-T*s) is a delay"
STRUCTURE_CHOICES = [
    ("lead", "K (1 + T1 s)/(1 + T2 s), T2 < T1"),
    ("lag", "K (1 + T1 s)/(1 + T2 s), T2 > T1"),
    ("gain", "K"),
    ("lead-lag", "two lead/lag pairs"),
    ("pi", "K (1 + Ti s)/(Ti s)"),
    ("pid", "K (1 + 1/(Ti s) + Td s/(1 + 0.1 Td s))"),
    ("expression", "type it (its names are the parameters)"),
]


class NewSessionFlow:
    """Asks what the new session is, then hands its JSON data to ``create``."""

    def __init__(self, app: Any, create: Callable[[dict, list[Path]], None]):
        self.app, self.create = app, create

    def start(self) -> None:
        self.app.push_screen(
            ChooseDialog("new session: which kind?", list(template_kinds.KINDS.items())),
            lambda kind: kind and getattr(self, "_" + kind.replace("-", "_"))(),
        )

    def _ask(
        self, title: str, check: Callable[[str], str | None], then: Callable[[str], None], value: str = ""
    ) -> None:
        self.app.push_screen(EditDialog(title, value, check), lambda text: text and then(text.strip()))

    def _structure(self, title: str, then: Callable[[str], None]) -> None:
        def chosen(name: str | None) -> None:
            if name == "expression":
                self._ask(f"{title}: the compensator, an expression in s", _compensator_check, then)
            elif name:
                then(name)

        self.app.push_screen(ChooseDialog(title, STRUCTURE_CHOICES), chosen)

    def _made(self, build: Callable[[], dict], tables: list[Path] = ()) -> None:
        try:
            data = build()
        except SessionError as exc:
            self.app.notify(str(exc), title="no new session", severity="error", timeout=10)
            return
        if "start" in data["problem"]["grid"] and data["problem"]["conditions"] and not tables:
            data = template_kinds.in_unit(data, self.app.config.unit)
        self.create(data, list(tables))

    def _unity(self) -> None:
        self._ask(
            f"plant: {PLANT_HINT}",
            _plant_check,
            lambda plant: self._structure(
                "compensator structure", lambda c: self._made(lambda: templates.new_session(plant, c))
            ),
        )

    def _digital(self) -> None:
        def plant(sample_time: float) -> None:
            self._ask(
                f"plant, every {sample_time:g} s: an expression in s (held: zero-order hold; exp(-T*s), the "
                "computational delay, as whole and fractional samples) or in z",
                _plant_check,
                lambda text: self._structure(
                    "compensator structure (in z by Tustin's map)",
                    lambda c: self._made(lambda: templates.new_session(text, c, sample_time=sample_time)),
                ),
            )

        self._ask("sample time T (s)", _sample_time_check, lambda text: plant(parse_sample_time(text)))

    def _matrix(self) -> None:
        self._ask(
            f"plant (matrix format): {PLANT_HINT}",
            _plant_check,
            lambda plant: self._structure(
                "compensator structure", lambda c: self._made(lambda: template_kinds.matrix_session(plant, c))
            ),
        )

    def _two_loops(self) -> None:
        def outer(inner_plant: str, inner: str) -> None:
            self._ask(
                f"outer plant (from the inner loop's output x to y): {PLANT_HINT}",
                _plant_check,
                lambda outer_plant: self._structure(
                    "outer compensator",
                    lambda c: self._made(lambda: template_kinds.two_loop_session(inner_plant, outer_plant, inner, c)),
                ),
            )

        self._ask(
            f"inner plant (from u to the inner signal x): {PLANT_HINT}",
            _plant_check,
            lambda inner_plant: self._structure("inner compensator", lambda c: outer(inner_plant, c)),
        )

    def _dae(self) -> None:
        self._made(template_kinds.dae_session)

    def _table(self) -> None:
        def columns(path: Path) -> None:
            header, preview = csv_preview(path)
            self._ask(
                f"{path.name}\n{preview}\n\ncolumns frequency,first,second form unit gain "
                "(guessed from the columns and rows above: check the form, polar or db, and the unit):",
                lambda t: _table_check(t, header),
                lambda line: self._structure(
                    "compensator structure", lambda c: self._made(lambda: _table_data(path, line, c), [path])
                ),
                guessed_table_line(header, preview),
            )

        self._ask(
            "CSV file of the plant's frequency response (path)",
            _csv_check,
            lambda text: columns(Path(text).expanduser()),
        )


def _check(read: Callable[[str], Any]) -> Callable[[str], str | None]:
    def check(text: str) -> str | None:
        try:
            read(text)
        except (SessionError, ValueError, OSError) as exc:
            return str(exc).removeprefix("--plant: ").removeprefix("--compensator: ")
        return None

    return check


_plant_check = _check(templates.read_plant)
_compensator_check = _check(lambda text: templates.read_compensator(text, "s"))
_csv_check = _check(lambda text: csv_preview(Path(text).expanduser()))
_sample_time_check = _check(parse_sample_time)


def _table_check(text: str, header: list[str]) -> str | None:
    return _check(lambda t: table_transfer(t, header, "table.csv"))(text)


def _table_data(path: Path, line: str, compensator: str) -> dict:
    header, _ = csv_preview(path)
    transfer = table_transfer(line, header, path.name)
    frequencies = read_csv(path, transfer["table"]["columns"], "table")[0]  # checked as the build reads it
    return template_kinds.table_session(transfer, frequencies, compensator)


def copy_tables(tables: list[Path], folder: Path) -> None:
    """The new session's CSV tables beside it (a session reads tables from its own folder)."""
    for table in tables:
        if table.resolve().parent != folder.resolve():
            shutil.copy2(table, folder / table.name)

"""The app's ways out, composed into the app (``app.exports``): ctrl+e exports the
current design (python-control or MATLAB script, JSON, CSV response) beside the
session, S saves a screenshot (Textual's SVG) beside it; neither overwrites a file
without asking."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from sessions.errors import SessionError
from sessions.export.formats import FORMATS, SUFFIX, export_text
from sessions.format.save_file import write_atomic
from tui.files import home

MAX_SCREENSHOTS = 1000  # of one iteration, named NAME_iterK-N.svg; past it the last one is asked over

if TYPE_CHECKING:
    from tui.app import LoopcraftApp


class Exports:
    """Exports and screenshots beside the session."""

    def __init__(self, app: LoopcraftApp) -> None:
        self.app = app

    def _beside(self, suffix: str) -> Path:
        """A file beside the session named after it and the iteration (the app's folder when untitled)."""
        bench = self.app.bench
        path = bench.session.path
        folder, stem = (path.parent, path.stem) if path is not None else (home(), "untitled")
        return folder / f"{stem}_iter{bench.iteration}{suffix}"

    def export(self) -> None:
        """Choose a format, then write the current iteration's design beside the session."""
        from tui.screens.dialogs import ChooseDialog

        if self.app.bench is None:
            return
        self.app.push_screen(
            ChooseDialog("export the current design as", list(FORMATS.items())), lambda to: to and self._export(to)
        )

    def _export(self, to: str) -> None:
        bench = self.app.bench
        try:
            text = export_text(bench.session, bench.iteration, to)
        except (SessionError, ValueError) as exc:
            self.app.notify(str(exc), title="not exported", severity="error", timeout=10)
            return
        self._write_asking(self._beside(SUFFIX[to]), text, f"the {to} export")

    def screenshot(self) -> None:
        """The screen as an SVG beside the session, under a name of its own (a screen is not a
        design: a second screenshot of an iteration is a second file, never a question)."""
        if self.app.bench is None:
            return
        target, n = self._beside(".svg"), 2
        while target.exists() and n < MAX_SCREENSHOTS:
            target, n = target.with_name(f"{self._beside('').name}-{n}.svg"), n + 1
        self._write_asking(target, self.app.export_screenshot(), "the screenshot")

    def _write_asking(self, target: Path, text: str, what: str) -> None:
        from tui.screens.dialogs import ConfirmDialog

        def write(yes: bool | None = True) -> None:
            if not yes:
                return
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
                write_atomic(target, text)
            except OSError as exc:
                self.app.notify(
                    f"{target}: {exc.strerror or exc}", title=f"{what} not written", severity="error", timeout=10
                )
                return
            self.app.notify(f"wrote {what} to {target}", timeout=6)

        if target.exists():
            self.app.push_screen(ConfirmDialog(f"{target.name} exists: replace it?"), write)
        else:
            write()

"""The app's ways out: ctrl+e exports the current design (python-control or
MATLAB script, JSON, CSV response) beside the session, S saves a screenshot
(Textual's SVG) beside it; neither overwrites a file without asking."""

from __future__ import annotations

from pathlib import Path

from sessions.errors import SessionError
from sessions.export.formats import FORMATS, SUFFIX, export_text
from sessions.format.save_file import write_atomic
from tui.files import home


class ExportActions:
    """A mixin of the app: needs ``bench``, ``notify``, ``push_screen``."""

    def _beside(self, suffix: str) -> Path:
        """A file beside the session named after it and the iteration (the app's folder when untitled)."""
        path = self.bench.session.path
        folder, stem = (path.parent, path.stem) if path is not None else (home(), "untitled")
        return folder / f"{stem}_iter{self.bench.iteration}{suffix}"

    def action_export(self) -> None:
        """Choose a format, then write the current iteration's design beside the session."""
        from tui.screens.dialogs import ChooseDialog

        if self.bench is None:
            return
        self.push_screen(
            ChooseDialog("export the current design as", list(FORMATS.items())), lambda to: to and self._export(to)
        )

    def _export(self, to: str) -> None:
        try:
            text = export_text(self.bench.session, self.bench.iteration, to)
        except (SessionError, ValueError) as exc:
            self.notify(str(exc), title="not exported", severity="error", timeout=10)
            return
        self._write_asking(self._beside(SUFFIX[to]), text, f"the {to} export")

    def action_save_screenshot(self) -> None:
        """The screen as an SVG beside the session."""
        if self.bench is None:
            return
        self._write_asking(self._beside(".svg"), self.export_screenshot(), "the screenshot")

    def _write_asking(self, target: Path, text: str, what: str) -> None:
        from tui.screens.dialogs import ConfirmDialog

        def write(yes: bool | None = True) -> None:
            if not yes:
                return
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
                write_atomic(target, text.encode("utf-8"))
            except OSError as exc:
                self.notify(
                    f"{target}: {exc.strerror or exc}", title=f"{what} not written", severity="error", timeout=10
                )
                return
            self.notify(f"wrote {what} to {target}", timeout=6)

        if target.exists():
            self.push_screen(ConfirmDialog(f"{target.name} exists: replace it?"), write)
        else:
            write()

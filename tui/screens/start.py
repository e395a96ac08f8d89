"""The start screen: bundled examples, recent sessions, open a path, new session."""

from __future__ import annotations

import json
from pathlib import Path

from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Vertical
from textual.screen import Screen
from textual.widgets import Label, OptionList

from tui.files import EXAMPLES, recent_sessions
from tui.widgets.footer import Footer


class StartScreen(Screen):
    """enter opens the highlighted session; o opens a path; n starts a new session."""

    BINDINGS = [
        Binding("o", "app.open", "open a file"),
        Binding("n", "app.new", "new session"),
        Binding("q", "app.quit", "quit"),
    ]
    DEFAULT_CSS = """
    StartScreen > Vertical { padding: 1 2; }
    StartScreen OptionList { height: 1fr; }
    """

    def compose(self) -> ComposeResult:
        self.entries: list[tuple[str, Path]] = []
        for path in sorted(EXAMPLES.glob("*.json")):
            notes = json.loads(path.read_text()).get("notes", "")
            self.entries.append((f"example  {path.stem:<24} {notes.split('. ')[0][:70]}", path))
        for path in recent_sessions():
            self.entries.append((f"recent   {path}", path))
        with Vertical():
            yield Label("[b]loopcraft[/b]  classical compensator design workbench")
            yield Label("enter: open   o: open a file   n: new session   q: quit")
            yield OptionList(*[text for text, _ in self.entries], id="choices")
        yield Footer()

    def on_option_list_option_selected(self, event: OptionList.OptionSelected) -> None:
        self.app.open_path(self.entries[event.option_index][1])

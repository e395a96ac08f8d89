"""Modal dialogs: edit a value with live validation, confirm, help, choose; each in a double
border, which shows where the dialog is without colour (as a focused table's or plot's
thick left edge does)."""

from __future__ import annotations

from collections.abc import Callable

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical, VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Input, Label, OptionList, Static

Validator = Callable[[str], str | None]  # text -> error message, or None when acceptable


class EditDialog(ModalScreen[str | None]):
    """One line of text, checked as it is typed; enter applies, escape cancels."""

    BINDINGS = [Binding("escape", "cancel", "cancel")]
    DEFAULT_CSS = """
    EditDialog { align: center middle; }
    EditDialog > Vertical { width: 70; height: auto; border: double $accent; padding: 0 1; background: $panel; }
    EditDialog #error { color: $error; height: auto; }
    EditDialog Label { width: 100%; }
    """

    def __init__(self, title: str, value: str, validate: Validator | None = None, error: str = ""):
        super().__init__()
        self.title_text, self.value, self.validate, self.error = title, value, validate, error

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Label(self.title_text, markup=False)
            yield Input(self.value, id="value")
            yield Static(self.error, id="error", markup=False)

    def on_mount(self) -> None:
        self.query_one(Input).cursor_blink = False

    def on_input_changed(self, event: Input.Changed) -> None:
        if event.value == self.value and self.error:
            return  # the text it was opened with keeps the reason it was refused
        error = self.validate(event.value) if self.validate else None
        self.query_one("#error", Static).update(error or "")

    def on_input_submitted(self, event: Input.Submitted) -> None:
        error = self.validate(event.value) if self.validate else None
        if error:
            self.query_one("#error", Static).update(error)
            return
        self.dismiss(event.value)

    def action_cancel(self) -> None:
        self.dismiss(None)


class QuestionDialog(ModalScreen):
    """A question answered by a key (the subclass's bindings call `answer`); ``KEYS``: the
    line under it that says the keys."""

    KEYS = ""
    DEFAULT_CSS = """
    QuestionDialog { align: center middle; }
    QuestionDialog > Vertical { width: 64; height: auto; border: double $warning; padding: 0 1; background: $panel; }
    QuestionDialog Label { width: 100%; }
    """

    def __init__(self, question: str):
        super().__init__()
        self.question = question

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Label(self.question, markup=False)
            yield Label(self.KEYS)

    def action_answer(self, answer: object) -> None:
        self.dismiss(answer)


class ConfirmDialog(QuestionDialog):
    """A yes/no question: y or enter answers yes, n or escape no."""

    BINDINGS = [Binding("y,enter", "answer(True)", "yes"), Binding("n,escape", "answer(False)", "no")]
    KEYS = "[b]y[/b] yes   [b]n[/b] no"


class StartDialog(QuestionDialog):
    """An edit that drops recorded iterations: which design the session starts from
    then.  y or enter: the design on screen ("design"), s: the saved start ("saved"),
    n or escape: no edit (None)."""

    BINDINGS = [
        Binding("y,enter", "answer('design')", "the design on screen"),
        Binding("s", "answer('saved')", "the saved start"),
        Binding("n,escape", "answer(None)", "cancel"),
    ]
    KEYS = (
        "[b]y[/b] start from the design on screen   [b]s[/b] back to the saved start   [b]n[/b] cancel\n"
        "(the answer holds for the rest of the session)"
    )


class ChooseDialog(ModalScreen[str | None]):
    """Pick one of several names."""

    BINDINGS = [Binding("escape", "cancel", "cancel")]
    DEFAULT_CSS = """
    ChooseDialog { align: center middle; }
    ChooseDialog > Vertical { width: 70; height: auto; max-height: 20; border: double $accent; background: $panel; }
    """

    def __init__(self, title: str, choices: list[tuple[str, str]], highlighted: int = 0):
        super().__init__()
        self.title_text, self.choices, self.highlighted = title, choices, highlighted

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Label(self.title_text, markup=False)
            yield OptionList(*[Text(f"{name}  {summary}") for name, summary in self.choices])

    def on_mount(self) -> None:
        self.query_one(OptionList).highlighted = self.highlighted

    def on_option_list_option_selected(self, event: OptionList.OptionSelected) -> None:
        self.dismiss(self.choices[event.option_index][0])

    def action_cancel(self) -> None:
        self.dismiss(None)


class HelpScreen(ModalScreen[None]):
    """Every key of the workbench, by where it acts (made from the bindings)."""

    BINDINGS = [Binding("escape,question_mark,q", "close", "close")]
    DEFAULT_CSS = """
    HelpScreen { align: center middle; }
    HelpScreen > VerticalScroll { width: 84; max-width: 100%; height: auto; max-height: 90%; border: double $accent;
                                  padding: 0 1;
                                  background: $panel; }
    HelpScreen Label { width: 100%; }
    HelpScreen .key-row { height: auto; }
    HelpScreen .key-row > .key { width: 19; text-style: bold; padding-left: 2; }
    HelpScreen .key-row > .what { width: 1fr; }
    """

    def __init__(self, groups: list[tuple[str, list[tuple[str, str]]]], note: str = ""):
        super().__init__()
        self.groups, self.note = groups, note

    def compose(self) -> ComposeResult:
        with VerticalScroll():
            yield Label("[b]loopcraft keys[/b]  (ctrl+p: the command palette)")
            if self.note:
                yield Label(self.note, markup=False)
            for title, keys in self.groups:
                yield Label(f"[b]{title}[/b]")
                for key, what in keys:  # a description wraps in its own column, under itself
                    with Horizontal(classes="key-row"):
                        yield Label(key, classes="key", markup=False)
                        yield Label(what, classes="what", markup=False)

    def action_close(self) -> None:
        self.dismiss(None)

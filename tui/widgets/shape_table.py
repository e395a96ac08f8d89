"""The shaping table: the plotted condition's compensators as an engineer reads them
(gain, zeros, poles, pairs, with the parameters behind each), moved by keys; every move
is an edit (undoable, one undo step per burst on one item) and every plot and the
tableau follow.  `C` on the Run tab shows it."""

from __future__ import annotations

import math

from textual.binding import Binding
from textual.widgets import DataTable

from sessions.errors import SessionError
from tui.keys import identified
from tui.state import edits

STEP, BIG_STEP = 1.05, 1.25  # frequency factors of a nudge (shift: a big one)
STEP_DB, BIG_STEP_DB = 0.5, 3.0  # the gain's nudges, dB
DAMPING_STEP = 1.1  # a pair's damping factor of a nudge


class ShapeTable(DataTable):
    """One row per compensator item; left/right move it, [ and ] a pair's damping, e types
    a value, g and G solve the loop gain for a crossover or a phase margin, + adds a part,
    N a notch on a resonance and - deletes the selected item."""

    BINDINGS = identified(
        "shape",
        [
            Binding("left", "nudge(-1)", "lower", tooltip="the item 5 % lower in frequency (a gain 0.5 dB)"),
            Binding("right", "nudge(1)", "higher", tooltip="the item 5 % higher in frequency (a gain 0.5 dB)"),
            Binding("shift+left", "nudge(-5)", "", show=False, tooltip="25 % lower (a gain 3 dB)"),
            Binding("shift+right", "nudge(5)", "", show=False, tooltip="25 % higher (a gain 3 dB)"),
            Binding("left_square_bracket", "damp(-1)", "damping -", tooltip="a pair's damping 10 % lower"),
            Binding("right_square_bracket", "damp(1)", "damping +", show=False, tooltip="a pair's damping 10 % higher"),
            Binding("e", "type_value", "set", tooltip="type the item's frequency (rad/s), or the gain"),
            Binding(
                "g", "gain_for('crossover')", "gain for wc", tooltip="the gain that puts the crossover at a frequency"
            ),
            Binding("G", "gain_for('pm')", "gain for PM", tooltip="the gain that gives a phase margin"),
            Binding("plus", "add", "add", tooltip="add a lead, lag, integrator, zero, pole, notch or pole pair"),
            Binding("minus,delete", "delete", "delete", tooltip="delete the selected zero, pole or pair (its factor)"),
            Binding("N", "notch", "notch", tooltip="a notch on one of the plant's resonances (zeros on its poles)"),
        ],
    )

    def __init__(self, **kwargs):
        super().__init__(cursor_type="row", **kwargs)
        self.names: list[str] = []
        self.found: list = []

    def fill(self, rows: list[tuple[str, str, object]]) -> None:
        """The items (name, reading, item), the cursor kept on its row."""
        row = self.cursor_row
        self.clear(columns=not self.columns)
        if not self.columns:
            self.add_columns("item", "reads")
        self.names = [name for name, _, _ in rows]
        self.found = [item for _, _, item in rows]
        for name, text, _ in rows:
            self.add_row(name, text)
        if rows:
            self.move_cursor(row=min(max(row, 0), len(rows) - 1))

    @property
    def selected(self) -> tuple[str, object] | None:
        k = self.cursor_row
        return (self.names[k], self.found[k]) if 0 <= k < len(self.names) else None

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        if action in ("nudge", "damp", "type_value", "gain_for", "add", "delete", "notch"):
            if self.app.busy or self.selected is None:
                return None
            if action == "damp":
                return True if self.selected[1].kind.endswith("pair") else None
            if action == "delete":
                return None if self.selected[1].kind == "gain" else True
        return True

    def action_nudge(self, steps: int) -> None:
        name, item = self.selected
        if item.kind == "gain":
            db = (STEP_DB if abs(steps) == 1 else BIG_STEP_DB) * (1 if steps > 0 else -1)
            self._move(name, 10 ** (db / 20), f"{name} {db:+g} dB")
        else:
            factor = (STEP if abs(steps) == 1 else BIG_STEP) ** (1 if steps > 0 else -1)
            self._move(name, factor, f"{name} x {factor:.4g}")

    def action_damp(self, direction: int) -> None:
        name, _ = self.selected
        self._move(f"{name}.zeta", DAMPING_STEP**direction, f"{name} damping x {DAMPING_STEP**direction:.3g}")

    def _move(self, name: str, scale: float, what: str) -> None:
        """Scale an item's measure (``name``: ``block.item`` or ``block.item.zeta``) as an edit;
        the nudges of one item, one burst."""
        bench = self.app.bench
        self.app.edit_flow.change(lambda: edits.move_item(bench, name, lambda now: now * scale), what, burst=name)

    def action_type_value(self) -> None:
        from engine.design.compensator_items import measure  # scipy: never before the first paint

        name, item = self.selected
        now = measure(item)
        unit = "" if item.kind == "gain" else " (rad/s)"

        def apply(text: str) -> None:
            edits.move_item(self.app.bench, name, lambda _: float(text))

        self.app.edit_flow.line(f"{name}{unit}: now {now:.6g}", _positive, apply, f"set {name}")

    def action_gain_for(self, goal: str) -> None:
        title = "the crossover frequency (rad/s)" if goal == "crossover" else "the phase margin (deg)"

        def apply(text: str) -> None:
            edits.gain_for(self.app.bench, goal, float(text))

        self.app.edit_flow.line(f"the loop gain for {title}", _number, apply, f"the gain for {goal} {title}")

    def action_add(self) -> None:
        from sessions.compensator_parts import PARTS  # scipy: never before the first paint

        block = self.selected[0].rsplit(".", 1)[0]
        bench = self.app.bench

        def add(kind: str) -> None:
            self.app.edit_flow.change(
                lambda: edits.add_part(bench, block, kind),
                f"add a {kind} to {block}",
                done=lambda text: self.app.notify(f"{text}: g re-solves the gain for the crossover", timeout=6),
            )

        self.app.edit_flow.choose(f"add to {block}", [(k, p.title) for k, p in PARTS.items()], add)

    def action_notch(self) -> None:
        block = self.selected[0].rsplit(".", 1)[0]
        bench = self.app.bench
        found = edits.resonances(bench)
        if not found:
            self.app.notify(
                "no pole pair of a fixed block is damped less than 0.3 (a tabulated plant has none to read): "
                "+ adds a notch about the crossover, e types its frequency",
                title="no resonance",
                timeout=8,
            )
            return

        def add(index: str) -> None:
            resonance = found[int(index)]
            self.app.edit_flow.change(
                lambda: edits.notch_on(bench, block, resonance),
                f"a notch on {resonance.text}",
                done=lambda text: self.app.notify(text, timeout=6),
            )

        self.app.edit_flow.choose(f"a notch in {block} on", [(str(k), r.text) for k, r in enumerate(found)], add)

    def action_delete(self) -> None:
        name, item = self.selected
        bench = self.app.bench
        try:
            plan = edits.remove_item(bench, name, item, bench.session.model.problem.model_copy(deep=True))
        except SessionError as exc:
            self.app.notify(str(exc), title=f"{name} cannot be deleted", severity="error", timeout=8)
            return
        self.app.edit_flow.change(
            lambda: edits.remove_item(bench, name, item),
            f"delete {name}: {plan}",
            always_ask=True,
            done=lambda text: self.app.notify(text, timeout=8),
        )


def _positive(text: str) -> str | None:
    try:
        value = float(text)
    except ValueError:
        return "a number"
    return None if value > 0 and math.isfinite(value) else "a positive, finite number"


def _number(text: str) -> str | None:
    try:
        value = float(text)
    except ValueError:
        return "a number"
    return None if math.isfinite(value) else "a finite number"

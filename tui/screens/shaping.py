"""The shaping table's requests applied to the session (`ShapeTable.Request`): one route
for every change a shaping key makes (a move, a typed value, a gain solve, a part added,
a notch, a deletion), each an edit through `EditFlow.change` (the design on screen made
the start first, one undo step per burst on one item).  A plot's drags
(`FigurePlot.Dragged`: a compensator's mark, the Bode magnitude, a locus branch) take the
same route, one drag one undo step.  A part composed into the main screen
(``screen.shaping``); the widgets only ask, this applies."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, cast

from sessions.errors import SessionError
from tui.state import edits
from tui.widgets.plots import FigurePlot
from tui.widgets.shape_table import ShapeTable

if TYPE_CHECKING:
    from engine.design.compensator_items import Item
    from sessions.shaping import GainChoice
    from tui.app import LoopcraftApp
    from tui.screens.edit_flow import EditFlow
    from tui.screens.main import MainScreen
    from tui.state.workbench import Workbench


class Shaping:
    """Applies the shaping table's requests; every change goes through `change`."""

    def __init__(self, screen: MainScreen) -> None:
        self.screen = screen
        self.dragging = Drag()  # the drag going on (its design at the press, what refused it last)

    @property
    def app(self) -> LoopcraftApp:
        return cast("LoopcraftApp", self.screen.app)

    @property
    def bench(self) -> Workbench:
        return self.screen.bench

    @property
    def flow(self) -> EditFlow:
        return self.app.edit_flow

    def handle(self, request: ShapeTable.Request) -> None:
        """Carry out one request of the table (the app may have become busy since it was posted)."""
        if self.app.busy:
            self.app.notify(f"{request.name}: not while a run or a sweep goes (space pauses it)", timeout=3)
            return
        if isinstance(request, ShapeTable.Move):
            self.move(request)
        elif isinstance(request, ShapeTable.TypeValue):
            self.type_value(request)
        elif isinstance(request, ShapeTable.GainFor):
            self.gain_for(request)
        elif isinstance(request, ShapeTable.Add):
            self.add(request)
        elif isinstance(request, ShapeTable.Notch):
            self.notch(request)
        elif isinstance(request, ShapeTable.Delete):
            self.delete(request)

    def change(
        self,
        change: Callable[[], object],
        what: str,
        *,
        burst: str | None = None,
        done: Callable[[object], None] | None = None,
        always_ask: bool = False,
    ) -> None:
        """The one route of a shaping key's change: an edit of the design on screen."""
        self.flow.change(change, what, always_ask=always_ask, done=done, burst=burst)

    def drag(self, message: FigurePlot.Dragged) -> None:
        """A handle dragged on a plot: the design follows the pointer, each position an edit
        of one burst (one undo step a drag), the tableau and the dragged plot redrawn, every
        plot on release; a position refused (a bound, a constraint) leaves the last one
        accepted, and the release, refused too, says why.  Where the first edit must ask
        where to start from (recorded iterations), the design moves on release alone."""
        key = (message.plot.id, message.drag)
        if self.dragging.key != key:
            self.dragging = Drag(key)
            self.screen.frame_times.forget(message.plot.id or "")  # its first frame goes to the worker
        self.screen.dragged_plot = None if message.done else message.plot.id  # the others on release
        if self.app.busy:
            if message.done:
                self.app.notify("a drag: not while a run or a sweep goes (space pauses it)", timeout=3)
                message.plot.refresh()  # its view given back
            return
        if not message.done and self.bench.iteration > 0 and self.bench.start is None:
            return  # the first edit asks where to start from: once, on release

        def refused(reason: str) -> None:
            if message.done:
                self.app.notify(reason, title="the drag stopped short", severity="warning", timeout=8)

        try:
            change, what = self.dragged(message)
        except SessionError as exc:
            refused(str(exc))
        else:
            self.flow.change(change, what, burst=("drag", *key), refused=refused)
        if message.done:
            self.bench.edits.end_burst()
            self.screen.refresh_plots()  # every plot of the design the drag left (those of no change too)
            self.screen.redraw_released(message.plot)

    def dragged(self, message: FigurePlot.Dragged) -> tuple[Callable[[], object], str]:
        """The edit that puts the dragged handle under the pointer, and what it does."""
        bench, handle, drag = self.bench, message.handle, self.dragging
        k = bench.view().first_plotted
        item = drag.item or handle.name  # the item pressed, by its name now
        if handle.motion == "root":
            root = complex(message.x, message.y)
            sampled = bench.session.problem.conditions[k].network.sample_time is not None  # drawn in z
            move = edits.move_root_in_z if sampled else edits.move_root
            return lambda: drag.moved(move(bench, item, root)), f"drag {item}"
        if handle.motion == "corner":
            unit = 2 * math.pi if bench.session.problem.grid.unit == "hz" else 1.0
            frequency = 10**message.x * unit
            return lambda: drag.moved(edits.move_corner(bench, item, frequency)), f"drag {item}"
        parameter = self.screen.view_actions.locus_parameter
        if handle.motion == "locus" and parameter != "gain":
            value = float(cast(float, message.value))
            return lambda: edits.set_parameters(bench, {parameter: value}, k), f"drag {parameter} along the locus"
        if drag.gain is None:  # the gain parameter and its value at the press
            # here: it imports scipy.optimize (1.4 s), which a root's or a corner's drag never needs
            from sessions.shaping import gain_parameter

            values = bench.session.problem.condition_values(k)
            name = gain_parameter(bench.session, k, values)
            drag.gain = (name, values[name])
        name, start = drag.gain
        factor = 10 ** ((message.y - handle.y) / 20) if handle.motion == "gain" else float(cast(float, message.value))
        return lambda: edits.set_parameters(bench, {name: start * factor}, k), f"drag the loop gain ({name})"

    def move(self, request: ShapeTable.Move) -> None:
        """Scale an item's frequency, damping or gain; the nudges of one item, one burst."""
        bench, scale = self.bench, request.scale
        self.change(
            lambda: edits.move_item(bench, request.measure, lambda now: now * scale),
            request.what,
            burst=request.measure,
        )

    def type_value(self, request: ShapeTable.TypeValue) -> None:
        from engine.design.compensator_items import measure  # scipy: never before the first paint

        bench, name = self.bench, request.name
        unit = "" if request.item.kind == "gain" else " (rad/s)"

        def apply(text: str) -> None:
            edits.move_item(bench, name, lambda _: float(text))

        item = cast("Item", request.item)  # the table's items are the engine's (`edits.compensator_rows`)
        self.flow.line(f"{name}{unit}: now {measure(item):.6g}", positive, apply, f"set {name}")

    def gain_for(self, request: ShapeTable.GainFor) -> None:
        """g: the gain for a crossover; G: every gain for a phase margin, one picked (`pick_gain`)."""
        bench = self.bench
        if request.goal == "pm":
            self.flow.ask("the loop gain for the phase margin (deg)", finite, lambda text: self.pick_gain(float(text)))
            return

        def apply(text: str) -> None:
            edits.gain_for(bench, "crossover", float(text))

        title = "the crossover frequency (rad/s)"
        self.flow.line(f"the loop gain for {title}", finite, apply, f"the gain for crossover {title}")

    def pick_gain(self, phase_margin: float) -> None:
        """Every gain that gives the phase margin, by crossover frequency, with what else it
        changes; one alone is taken, several are listed (the default highlighted: the first
        that keeps every met requirement met, else the lowest crossover)."""
        from sessions.shaping import default_choice

        try:
            choices = edits.phase_margin_choices(self.bench, phase_margin)
        except SessionError as exc:
            self.app.notify(str(exc), title="no gain gives that phase margin", severity="error", timeout=10)
            return
        what = f"the gain for PM {phase_margin:g} deg"
        if len(choices) == 1:
            self.take_gain(choices[0], what)
            return
        default = default_choice(choices)
        listed = [(str(k + 1), c.text + ("  [default]" if k == default else "")) for k, c in enumerate(choices)]
        self.flow.choose(
            f"{what}: {len(choices)} solutions",
            listed,
            lambda k: self.take_gain(choices[int(k) - 1], what),
            highlighted=default,
        )

    def take_gain(self, choice: GainChoice, what: str) -> None:
        bench, k = self.bench, self.bench.view().first_plotted
        self.change(
            lambda: edits.scale_gain(bench, k, choice.solution.factor),
            f"{what} at {choice.solution.frequency:.4g} rad/s",
            done=lambda _: self.app.notify(choice.text, timeout=6),
        )

    def add(self, request: ShapeTable.Add) -> None:
        from sessions.compensator_parts import PARTS  # scipy: never before the first paint

        bench, block = self.bench, request.block

        def add(kind: str) -> None:
            self.change(
                lambda: edits.add_part(bench, block, kind),
                f"add a {kind} to {block}",
                done=lambda text: self.app.notify(f"{text}: g re-solves the gain for the crossover", timeout=6),
            )

        self.flow.choose(f"add to {block}", [(k, p.title) for k, p in PARTS.items()], add)

    def notch(self, request: ShapeTable.Notch) -> None:
        bench, block = self.bench, request.block
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
            self.change(
                lambda: edits.notch_on(bench, block, resonance),
                f"a notch on {resonance.text}",
                done=lambda text: self.app.notify(str(text), timeout=6),
            )

        self.flow.choose(f"a notch in {block} on", [(str(k), r.text) for k, r in enumerate(found)], add)

    def delete(self, request: ShapeTable.Delete) -> None:
        bench, name, item = self.bench, request.name, cast("Item", request.item)  # the engine's (`type_value`)
        try:
            plan = edits.remove_item(bench, name, item, bench.session.model.problem.model_copy(deep=True))
        except SessionError as exc:
            self.app.notify(str(exc), title=f"{name} cannot be deleted", severity="error", timeout=8)
            return
        self.change(
            lambda: edits.remove_item(bench, name, item),
            f"delete {name}: {plan}",
            always_ask=True,
            done=lambda text: self.app.notify(str(text), timeout=8),
        )


class Drag:
    """The drag going on: its key (plot, count), the gain parameter and its value at the
    press (a gain or locus drag scales from there), and the dragged item's name now
    (items are numbered by frequency: a zero dragged past another of its kind takes the
    other's number, and the drag goes on moving it, not the item now called as it was)."""

    def __init__(self, key: tuple[object, ...] = ()) -> None:
        self.key = key
        self.gain: tuple[str, float] | None = None
        self.item: str | None = None

    def moved(self, item: str) -> str:
        """An accepted move left the dragged item named ``item``."""
        self.item = item
        return item


def positive(text: str) -> str | None:
    """None when the text is a positive, finite number, else what it must be."""
    try:
        value = float(text)
    except ValueError:
        return "a number"
    return None if value > 0 and math.isfinite(value) else "a positive, finite number"


def finite(text: str) -> str | None:
    """None when the text is a finite number, else what it must be."""
    try:
        value = float(text)
    except ValueError:
        return "a number"
    return None if math.isfinite(value) else "a finite number"

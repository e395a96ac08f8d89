"""The plot widget: a `Figure` drawn on a text canvas (`tui.drawing.text_canvas`), with
keys and the mouse to zoom, pan and move a data tip (`tui.figures.navigation`), and the
mouse to drag the figure's handles (a compensator's marks, the Bode magnitude, a locus
branch): the widget only says where the pointer is (`FigurePlot.Dragged`)."""

from __future__ import annotations

from dataclasses import dataclass
from operator import attrgetter

from rich.cells import cell_len
from rich.segment import Segment
from rich.style import Style as RichStyle
from rich.text import Text
from textual import events
from textual._context import active_app
from textual.binding import Binding
from textual.message import Message
from textual.strip import Strip
from textual.style import Style
from textual.visual import RenderOptions, RichVisual
from textual.widget import Widget
from textual_plotext import PlotextPlot

from tui.drawing.text_canvas import Drawing, Frame, draw
from tui.figures.data import Figure, Handle
from tui.figures.navigation import Navigation, Probe, grab, nearest_index, xy_probe
from tui.keys import identified

Canvas = tuple[int, int, str]  # (width, height, plotext theme)
Held = tuple[tuple[float, float, float, float] | None, int | None]  # a view's box and cursor (`FigurePlot.held`)
Prebuilt = tuple[tuple[Canvas, Held], Drawing | None]


@dataclass(frozen=True)
class Grip:
    """A handle grabbed by a press: the figure's probe then (a locus drag picks along it),
    the data area pressed (the pointer's data point during the drag) and the view before
    (the view is held still while dragging, then given back)."""

    handle: Handle
    probe: Probe | None
    frame: Frame
    box: tuple[float, float, float, float] | None


def _cells_per_unit(frame: Frame) -> tuple[float, float]:
    """Cells per data unit across and up (a row is about two columns tall): nearness as the eye sees it."""
    (x0, x1), (y0, y1) = frame.xlim, frame.ylim
    return (frame.right - frame.left) / ((x1 - x0) or 1.0), 2 * (frame.bottom - frame.top) / ((y1 - y0) or 1.0)


class FigurePlot(PlotextPlot):
    """A plot drawn from a `Figure`.  `show` draws on the next render;
    `prebuild` (any thread) draws into text that `show` can hand over, so a
    worker thread can take the drawing off the UI thread.  Focused, it zooms,
    pans and moves a cursor along the current curve (`navigation`)."""

    can_focus = True
    ALLOW_SELECT = False  # a press pans or drags: no text selection (Textual repainted the whole screen each move)
    DEFAULT_CSS = """
    FigurePlot { border-left: blank; }
    FigurePlot:focus { border-left: thick $accent; }
    """
    BINDINGS = identified(
        "plot",
        [
            Binding(
                "plus,equals_sign", "zoom(1.5)", "zoom in", tooltip="zoom in (about the cursor)", id="plot.zoom_in"
            ),
            Binding("minus", "zoom(0.6666666666666666)", "zoom out", id="plot.zoom_out"),
            Binding(
                "left",
                "cursor(-1)",
                "cursor",
                id="plot.cursor_left",
                tooltip="the cursor along the curve (Poles: pole to pole, zeta, wn)",
            ),
            Binding("right", "cursor(1)", "cursor", show=False, id="plot.cursor_right"),
            Binding("shift+left", "cursor(-10)", "", show=False, id="plot.cursor_left_10"),
            Binding("shift+right", "cursor(10)", "", show=False, id="plot.cursor_right_10"),
            Binding(
                "v",
                "ask_value",
                "go to",
                tooltip="the cursor to a typed value of x (on a frequency axis, the frequency)",
                id="plot.go_to",
            ),
            Binding("h", "pan(-0.25, 0)", "pan", tooltip="pan: h j k l", id="plot.pan_left"),
            Binding("l", "pan(0.25, 0)", "", show=False, id="plot.pan_right"),
            Binding("k", "pan(0, 0.25)", "", show=False, id="plot.pan_up"),
            Binding("j", "pan(0, -0.25)", "", show=False, id="plot.pan_down"),
            Binding("0", "reset_view", "reset", tooltip="the whole plot, no cursor"),
            Binding(
                "enter",
                "choose",
                "adopt",
                tooltip="the root locus: adopt the gain (or parameter value) at the cursor",
                id="plot.choose",
            ),
        ],
    )

    class Chosen(Message):
        """enter on a point whose probe picks a value (`Probe.chosen`: a locus's gain)."""

        def __init__(self, plot: FigurePlot, value: object) -> None:
            super().__init__()
            self.plot, self.value = plot, value

    class AskValue(Message):
        """v: the cursor to a typed value (the screen asks for it, then calls `go_to`)."""

        def __init__(self, plot: FigurePlot) -> None:
            super().__init__()
            self.plot = plot

    class Navigated(Message):
        """Zoomed, panned or its cursor moved (a linked panel follows: `follow`)."""

        def __init__(self, plot: FigurePlot) -> None:
            super().__init__()
            self.plot = plot

    class Dragged(Message):
        """A handle (`Figure.handles`, or the figure's curve) dragged: the pointer at data
        (x, y); ``value`` the locus's value at the point nearest it (a "locus" drag, on the
        locus as pressed); ``done`` on release (the view given back: the screen draws the
        plot again, `MainScreen.redraw_released`); ``drag`` counts the plot's drags (each
        one undo step)."""

        def __init__(
            self, plot: FigurePlot, handle: Handle, x: float, y: float, value: object, done: bool, drag: int
        ) -> None:
            super().__init__()
            self.plot, self.handle, self.x, self.y = plot, handle, x, y
            self.value, self.done, self.drag = value, done, drag

        def can_replace(self, message: Message) -> bool:
            """A position not yet handled gives way to the next one of the same drag (Textual
            drops this message for it): a pointer that moves faster than frames are drawn is
            followed to where it is, not through every cell it crossed."""
            same = isinstance(message, FigurePlot.Dragged) and (message.plot, message.drag) == (self.plot, self.drag)
            return same and not self.done

    class Shown(Message):
        """The plot came on screen (its tab shown, the screen resumed): whatever it shows
        may be of an earlier design, so the screen checks it against the current one."""

        def __init__(self, plot: FigurePlot) -> None:
            super().__init__()
            self.plot = plot

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.set_reactive(FigurePlot.auto_links, False)  # a plot has no links: its strips are not restyled for them
        self.figure = Figure()
        self.navigation = Navigation()
        self._prebuilt: Prebuilt | None = None
        self.drawing: Drawing | None = None  # the last drawn (where its panels' data areas are)
        self.image: Widget | None = None  # the image widget of a graphics terminal (None: text)
        self._imaged: tuple | None = None  # what the image shows: (figure, navigation, canvas)
        self._drag: tuple[int, int] | None = None  # the cell a mouse button went down on
        self._dragged = False
        self._grip: Grip | None = None  # the handle a press grabbed (None: a press pans)
        self._drags = 0  # the handle drags so far (each names its undo step)

    def navigated(self) -> None:
        """Draw the new view and say so (a linked panel follows)."""
        self.refresh()
        self.post_message(self.Navigated(self))

    def follow(self, leader: FigurePlot) -> None:
        """Take a linked panel's x range and cursor (`Navigation.follow`)."""
        self.navigation.follow(self.figure, leader.navigation)
        self.refresh()

    def action_zoom(self, factor: float) -> None:
        self.navigation.zoom(self.figure, factor)
        self.navigated()

    def action_pan(self, dx: float, dy: float) -> None:
        self.navigation.pan(self.figure, dx, dy)
        self.navigated()

    def action_cursor(self, step: int) -> None:
        """The cursor ``step`` columns of the view along the curve (points where it doubles back)."""
        frame = self.drawing.frames[0] if self.drawing is not None and len(self.drawing.frames) == 1 else None
        column = None if frame is None else (frame.xlim[1] - frame.xlim[0]) / max(frame.right - frame.left, 1)
        self.navigation.move(self.figure, step, column)
        self.navigated()

    def action_ask_value(self) -> None:
        self.post_message(self.AskValue(self))

    def go_to(self, value: float) -> bool:
        """The cursor to the point nearest a value of x (`Navigation.go_to`); False: none."""
        moved = self.navigation.go_to(self.figure, value)
        if moved:
            self.navigated()
        return moved

    def check_action(self, action: str, parameters: tuple[object, ...]) -> bool | None:
        """enter acts only on a cursor over a probe that picks a value (a root locus)."""
        return None if action == "choose" and self._choosable() is None else True

    def action_choose(self) -> None:
        probe = self._choosable()
        if probe is not None:
            self.post_message(self.Chosen(self, probe.chosen(self.navigation.cursor)))

    def _choosable(self):
        """The probe under the cursor when enter picks a value on it (else None)."""
        probe = self.navigation.probe(self.figure)
        chooses = probe is not None and probe.chosen is not None and self.navigation.cursor is not None
        return probe if chooses else None

    def action_reset_view(self) -> None:
        self.navigation.reset()
        self.navigated()

    def on_mouse_scroll_up(self, event: events.MouseScrollUp) -> None:
        self._zoom_at(event, 1.25)

    def on_mouse_scroll_down(self, event: events.MouseScrollDown) -> None:
        self._zoom_at(event, 0.8)

    def _zoom_at(self, event: events.MouseEvent, factor: float) -> None:
        """The wheel zooms about the data point under the pointer (else about the cursor)."""
        cell = self._cell(event)
        frame = self._frame(cell)
        if frame is None:
            self.action_zoom(factor)
            return
        self.navigation.zoom_at(self.figure, factor, frame.point(*cell))
        self.navigated()

    def on_mouse_down(self, event: events.MouseDown) -> None:
        """A press on a handle grabs it (the view held still while it is dragged), else pans."""
        self._drag, self._dragged = self._cell(event), False
        frame = self._frame(self._drag)
        handle = None if frame is None else grab(self.figure, *frame.point(*self._drag), _cells_per_unit(frame))
        if handle is not None and frame is not None:
            self._drags += 1
            self._grip = Grip(handle, self.navigation.probe(self.figure), frame, self.navigation.box)
            self.navigation.box = (*frame.xlim, *frame.ylim)
        self.capture_mouse()

    def on_mouse_move(self, event: events.MouseMove) -> None:
        """A drag moves the grabbed handle, else pans: the data under the pointer follows it."""
        if self._drag is None:
            return
        offset = event.get_content_offset_capture(self)  # the mouse is captured: it may leave the plot
        cell = (offset.x, offset.y)
        if self._grip is not None:
            if cell != self._drag:
                self._drag, self._dragged = cell, True
                self._post_drag(cell, done=False)
            return
        frame = self._frame(self._drag)
        if frame is None or cell == self._drag:
            return
        x0, y0 = frame.point(*self._drag)
        x1, y1 = frame.point(*cell)
        self.navigation.shift(self.figure, x0 - x1, y0 - y1)
        self._drag, self._dragged = cell, True
        self.navigated()

    def on_mouse_up(self, event: events.MouseUp) -> None:
        """A drag's release commits it; a click (no drag) puts the data tip on the nearest
        point of the nearest curve."""
        self.release_mouse()
        clicked, self._drag = self._drag is not None and not self._dragged, None
        grip, self._grip = self._grip, None
        if grip is not None:
            self.navigation.box = grip.box
            if not clicked:  # the screen draws it again, in the view given back (a new figure, or this one)
                offset = event.get_content_offset_capture(self)
                self._post_drag((offset.x, offset.y), done=True, grip=grip)
                return
            self.refresh()
        cell = self._cell(event)
        frame = self._frame(cell)
        if clicked and frame is not None:
            self.navigation.pick(self.figure, *frame.point(*cell), _cells_per_unit(frame))
            self.navigated()

    def _post_drag(self, cell: tuple[int, int], done: bool, grip: Grip | None = None) -> None:
        """Say where the grabbed handle is dragged to (in the data units of the press's view)."""
        grip = grip or self._grip
        if grip is None:
            return
        x, y = grip.frame.point(*cell)
        value = None
        if grip.handle.motion == "locus" and grip.probe is not None and grip.probe.chosen is not None:
            value = grip.probe.chosen(nearest_index(grip.probe, x, y, _cells_per_unit(grip.frame)))
        self.post_message(self.Dragged(self, grip.handle, x, y, value, done, self._drags))

    def _cell(self, event: events.MouseEvent) -> tuple[int, int] | None:
        offset = event.get_content_offset(self)
        return None if offset is None else (offset.x, offset.y)

    def _frame(self, cell: tuple[int, int] | None) -> Frame | None:
        """The data area of the drawing at a cell (one panel's; none on a figure of panels)."""
        if cell is None or self.drawing is None or self.figure.panels:
            return None
        return next((f for f in self.drawing.frames if f.contains(*cell)), None)

    @property
    def shown(self) -> Figure:
        """The figure as drawn: zoomed, with the cursor (`navigation`)."""
        return self.navigation.applied(self.figure)

    def show(self, figure: Figure, prebuilt: Prebuilt | None = None) -> None:
        self.figure, self._prebuilt = with_probe(figure), prebuilt
        self.navigation.forget_pick()
        self.refresh()

    def on_show(self) -> None:
        self.post_message(self.Shown(self))

    def on_mount(self) -> None:
        """Where the terminal shows images (`tui.drawing.graphics`, the `plots = "image"`
        setting), the figure is drawn as an image in a child widget that speaks its protocol."""
        graphics = getattr(self.app, "graphics", None)
        if graphics is not None:
            self.image = graphics.widget()
            self.image.styles.width, self.image.styles.height = "100%", "1fr"
            self.image.styles.margin = (0, 0, 1, 0)  # a sixel touching the last row moves the cursor off the screen
            self.mount(self.image)

    def canvas(self) -> Canvas:
        """(width, height, plotext theme) of the next render."""
        return self.content_size.width, self.content_size.height, self._get_plotext_theme_name(self.app.theme)

    def held(self) -> Held:
        """The view (box, cursor) a new figure will be shown in (`show` forgets a picked
        curve's cursor): what `prebuild` draws a figure in, so that a zoomed plot, or one
        held still while a handle is dragged, takes the worker's drawing too."""
        return self.navigation.box, None if self.navigation.picked is not None else self.navigation.cursor

    @staticmethod
    def prebuild(figure: Figure, canvas: Canvas, held: Held = (None, None)) -> Prebuilt:
        """The figure drawn at a canvas in a held view (any thread: a worker takes the
        drawing off the UI thread)."""
        return (canvas, held), draw(Navigation(*held).applied(with_probe(figure)), *canvas)

    def render(self) -> RichVisual | str:
        """The drawing's text as strips (`DrawingVisual`), the cells Rich draws: Textual's own
        conversion of a Rich text (`visualize` makes it `Content`, span by span) took 27-72 ms
        for a Bode drawing at 120x40 (about 90 coloured runs) where Rich's render took 3-4 ms,
        on every paint of a new figure."""
        if self.image is not None:
            return self._render_image()
        held = (self.navigation.box, self.navigation.cursor)
        if self._prebuilt is not None and self._prebuilt[0] == (self.canvas(), held) and self.navigation.picked is None:
            self.drawing = self._prebuilt[1]
        else:
            self.drawing = draw(self.shown, *self.canvas())
        if self.drawing is None:
            return f"{self.figure.title}: cannot draw at this size" if self.content_size.width else ""
        return DrawingVisual(self, self.drawing.text)

    def _render_image(self) -> str:
        """Nothing here: the image child shows the figure, drawn anew (after this paint,
        never inside it) when the figure, the view or the size changed."""
        width, height, _ = self.canvas()
        key = (repr(self.navigation), width, height, self.app.current_theme.dark)
        imaged = self._imaged
        if width >= 10 and height >= 5 and (imaged is None or imaged[0] is not self.figure or imaged[1:] != key):
            self._imaged = (self.figure, *key)  # the figure by identity: comparing its series would cost a pass
            self.call_later(self._draw_image)
        return ""

    def _draw_image(self) -> None:
        from tui.drawing import image_canvas  # matplotlib: only on a graphics terminal, never before the first paint

        width, height, _ = self.canvas()
        picture, frames = image_canvas.draw(self.shown, (width, height - 1), self.app.graphics.cell, self._imaged[-1])
        self.image.image = picture
        for part in [self.image, *self.image.walk_children()]:  # rows the image leaves uncovered: its own colour
            part.styles.background = image_canvas.face(self._imaged[-1])
        self.drawing = Drawing(Text(""), frames)


class DrawingVisual(RichVisual):
    """A drawing's text made strips straight from its runs: one segment a run of its spans (or
    of no span) within a line, in the widget's style plus the run's, the strips `RichVisual`
    makes through Rich's render, wrap and line split (`tests/tui/test_text_layers.py` checks
    them segment by segment); a text it does not read so (a base style, overlapping spans, a
    tab, a line wider than the widget, a justified text or widget) goes through `RichVisual`."""

    def render_strips(self, width: int, height: int | None, style: Style, options: RenderOptions) -> list[Strip]:
        text = self._renderable
        runs = self._runs(text, width) if isinstance(text, Text) else None
        if runs is None:
            return super().render_strips(width, height, style, options)
        base, get_style, null = style.rich_style, active_app.get().console.get_style, RichStyle.null()
        strips, line = [], []
        for chunk, run_style in runs:
            styled = base + (null if run_style is None else get_style(run_style, default=null))
            first, *rest = chunk.split("\n")
            if first:
                line.append(Segment(first, styled))
            for part in rest:
                strips.append(Strip(line))
                line = [Segment(part, styled)] if part else []
        strips.append(Strip(line))
        return strips[:height] if height is not None else strips

    def _runs(self, text: Text, width: int) -> list[tuple[str, object]] | None:
        """The text's runs in order, each with its span's style (None: no span); None when the
        text is not read this way."""
        plain = text.plain
        justified = text.justify not in (None, "default") or self._widget._get_justify_method() is not None
        if text.style or "\t" in plain or justified:
            return None
        if any(cell_len(line) > width for line in plain.split("\n")):
            return None  # Rich wraps it
        runs: list[tuple[str, object]] = []
        at = 0
        for span in sorted(text.spans, key=attrgetter("start")):
            if span.start < at:
                return None  # overlapping spans: Rich combines their styles
            if span.start > at:
                runs.append((plain[at : span.start], None))
            if span.end > span.start:
                runs.append((plain[span.start : span.end], span.style))
            at = max(at, span.end)
        if at < len(plain):
            runs.append((plain[at:], None))
        return runs


def with_probe(figure: Figure) -> Figure:
    """The figure with a cursor probe: its own, else one along its first curve (a cursor on any
    plot), set before it is drawn anywhere, so that a worker's drawing in a held view has the
    cursor a drawing on the UI thread would."""
    if figure.probe is None:
        first = next((s for s in figure.series if s.x and not s.scatter), None)
        if first is not None:
            figure.probe = xy_probe(first, figure.xlabel or "x", figure.ylabel or "y")
    return figure

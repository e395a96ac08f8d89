"""What a paint costs (issue 54, section 3): a plot's drawing is turned into cells by Rich,
never converted span by span into Textual's `Content` (27-72 ms for a Bode drawing at
120x40 in a microbench, Rich's render 3-4 ms; on every new figure), with the same cells
as Textual's own conversion draws; a nudge sets the tableau once."""

from __future__ import annotations

from rich.text import Text
from textual.app import App, ComposeResult
from textual.content import Content
from textual.strip import Strip
from textual.visual import Visual, visualize

from tests.tui.test_app import settle, synchronous
from tests.tui.test_shape_table import lead_app
from tui.figures.data import Figure, Series
from tui.widgets.plots import FigurePlot


class PlotApp(App):
    def compose(self) -> ComposeResult:
        yield FigurePlot(id="plot")


def _cells(strip: Strip) -> list[tuple[str, object, object, bool]]:
    """Each cell of a strip: its character, colours and weight."""
    return [(ch, s.style.color, s.style.bgcolor, bool(s.style.bold)) for s in strip for ch in s.text if s.style]


def _bode_like() -> Figure:
    figure = Figure(title="Bode magnitude", xlabel="rad/s", ylabel="dB")
    xs = [10 ** (k / 20 - 1) for k in range(61)]
    figure.series.append(Series(xs, [-20 * k / 20 for k in range(61)], "L(jw)"))
    figure.series.append(Series(xs, [5.0 - k / 10 for k in range(61)], "C(jw)"))
    return figure


@synchronous
async def test_a_plot_is_drawn_by_rich_with_textuals_cells(monkeypatch):
    """A plot's paint converts no Rich text into `Content` (before: the whole drawing, each
    new figure); its cells are those of Textual's conversion, line for line."""
    converted: list[Text] = []
    from_rich_text = Content.from_rich_text

    def noted(text, *args, **kwargs):
        converted.append(text)
        return from_rich_text(text, *args, **kwargs)

    monkeypatch.setattr(Content, "from_rich_text", noted)
    app = PlotApp()
    async with app.run_test(size=(80, 24)) as pilot:
        plot = app.query_one(FigurePlot)
        plot.show(_bode_like())
        await pilot.pause()
        shown = app.export_screenshot()
        assert plot.drawing is not None and "Bode magnitude" in plot.drawing.text.plain
        assert converted == [] and "magnitude" in shown
        width, height = plot.size
        ours = Visual.to_strips(plot, plot.render(), width, height, plot.visual_style)
        textuals = Visual.to_strips(plot, visualize(plot, plot.drawing.text), width, height, plot.visual_style)
        assert len(ours) == len(textuals) == height and sum(len(_cells(a)) for a in ours) > width * height // 2
        assert [_cells(a) for a in ours] == [_cells(b) for b in textuals]


@synchronous
async def test_a_nudge_sets_the_tableau_once_with_its_pole_lines(tmp_path, monkeypatch):
    """A nudge's tableau waits for its closed-loop pole lines (made by a thread worker) and
    is set once, with them (before: set with the lines "computing", then again when they
    came: two paints of the whole tableau a nudge).  The wait is made long here, so that
    the count does not hang on how fast the worker is; `test_the_pole_lines_...` below
    checks that a tableau whose lines are late is drawn without them."""
    from tui.screens import pole_lines
    from tui.widgets.textview import TextView

    monkeypatch.setattr(pole_lines, "WAIT_S", 3600.0, raising=False)
    app = lead_app(tmp_path, monkeypatch)
    shown: list[str] = []
    set_text = TextView.set

    def noted_set(view, text):
        before = view.text
        set_text(view, text)
        if view.id == "tableau" and view.text is not before:
            shown.append(view.text.plain)

    monkeypatch.setattr(TextView, "set", noted_set)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C", "down", "right")
        await settle(app, pilot)
        for key in ("left", "right", "left"):
            shown.clear()
            await pilot.press(key)
            for _ in range(200):  # the pole lines come
                await settle(app, pilot)
                if shown:
                    break
            await settle(app, pilot)
            assert len(shown) == 1 and "poles" in shown[0] and pole_lines.COMPUTING not in shown[0], shown


@synchronous
async def test_the_pole_lines_that_come_late_are_shown_computing_first(tmp_path, monkeypatch):
    """A tableau whose pole lines have not come within `WAIT_S` is drawn with them computing
    (the worker held here until the tableau is drawn), then with them."""
    import threading

    from tui.screens import pole_lines

    app = lead_app(tmp_path, monkeypatch)
    release, under = threading.Event(), pole_lines.under_tableau
    monkeypatch.setattr(pole_lines, "under_tableau", lambda view: release.wait(60) and under(view))
    async with app.run_test(size=(120, 40)) as pilot:
        tableau = app.screen.query_one("#tableau")
        for _ in range(400):  # the first tableau, its pole lines held
            await pilot.pause(0.01)
            if pole_lines.COMPUTING in tableau.text.plain:
                break
        assert pole_lines.COMPUTING in tableau.text.plain and "PM deg" in tableau.text.plain
        release.set()
        for _ in range(400):
            await settle(app, pilot)
            if pole_lines.COMPUTING not in tableau.text.plain:
                break
        assert pole_lines.COMPUTING not in tableau.text.plain and "poles" in tableau.text.plain

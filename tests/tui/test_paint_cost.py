"""What a paint redraws (issue 54, section 3): a text view redraws only the lines whose
text changed, and a plot's drawing is turned into cells by Rich, never converted span by
span into Textual's `Content` (20-70 ms a plot at 120x40 on every new figure), with the
same cells as Textual's own conversion draws."""

from __future__ import annotations

from rich.text import Text
from textual.app import App, ComposeResult
from textual.content import Content
from textual.strip import Strip
from textual.visual import Visual, visualize

from tests.tui.test_app import synchronous
from tui.figures.data import Figure, Series
from tui.widgets.plots import FigurePlot
from tui.widgets.textview import TextView

LINES = [f"line {k}: value {k * 1.5:.3f}" for k in range(10)]


class ViewApp(App):
    def compose(self) -> ComposeResult:
        yield TextView("\n".join(LINES), id="view")


class PlotApp(App):
    def compose(self) -> ComposeResult:
        yield FigurePlot(id="plot")


def _painted_lines(monkeypatch) -> list[int]:
    """The lines of any text view drawn from now on (its `render_line` calls)."""
    drawn: list[int] = []
    render_line = TextView.render_line

    def noted(view, y):
        drawn.append(y)
        return render_line(view, y)

    monkeypatch.setattr(TextView, "render_line", noted)
    return drawn


@synchronous
async def test_a_text_view_redraws_only_the_lines_that_changed(monkeypatch):
    """Before, any change redrew every line (the tableau's fifteen on each nudge, twice)."""
    app = ViewApp()
    async with app.run_test(size=(60, 14)) as pilot:
        await pilot.pause()
        view = app.query_one(TextView)
        app.export_screenshot()  # every line drawn once
        drawn = _painted_lines(monkeypatch)
        changed = list(LINES)
        changed[3] = "line 3: value 99.000"
        view.set(Text("\n".join(changed), style="bold", end="\n"))
        view.set(Text("\n".join(changed), style="bold", end="\n"))  # the same again: nothing more
        shown = app.export_screenshot()  # draws what is dirty, as a paint does
        assert drawn == list(range(10))  # the text's style changed: every line
        drawn.clear()
        changed[7] = "line 7: now longer than it was"
        view.set(Text("\n".join(changed), style="bold", end="\n"))
        shown = app.export_screenshot()
        assert drawn == [7] and "longer" in shown and "99.000" in shown
        assert view.size.height == 10
        view.set("\n".join([*changed, "an eleventh line"]))  # one line more: laid out again, all drawn
        await pilot.pause()
        app.export_screenshot()
        assert view.size.height == 11 and sorted(set(drawn)) == list(range(11))


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

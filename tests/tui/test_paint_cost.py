"""What a paint costs (issue 54, section 3): a plot's drawing is turned into cells by Rich,
never converted span by span into Textual's `Content` (27-72 ms for a Bode drawing at
120x40 in a microbench, Rich's render 3-4 ms; on every new figure), with the same cells
as Textual's own conversion draws."""

from __future__ import annotations

from rich.text import Text
from textual.app import App, ComposeResult
from textual.content import Content
from textual.strip import Strip
from textual.visual import Visual, visualize

from tests.tui.test_app import synchronous
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
async def test_a_nudge_on_a_tabulated_loop_lays_out_nothing(workdir, monkeypatch):
    """A nudge changes no widget's size, so the screen is not laid out again (issue 54,
    section 3).  The launch vehicle's loop is tabulated: its pole lines are none, and the
    tableau drawn while they were computed said "computing" on two more lines, then lost
    them: two layout passes a nudge (37-56 ms each at 120x40)."""
    from textual.screen import Screen

    from tests.tui.test_app import settle
    from tui.app import LoopcraftApp

    layouts = []
    refresh_layout = Screen._refresh_layout

    def counted(self, *args, **kwargs):
        layouts.append(self)
        return refresh_layout(self, *args, **kwargs)

    monkeypatch.setattr(Screen, "_refresh_layout", counted)
    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C", "down", "down", "right")  # the first compensator's zero1, moved once
        await settle(app, pilot)
        layouts.clear()
        before = app.bench.session.model.problem.model_dump()
        for key in ("right", "left", "right"):
            await pilot.press(key)
            await settle(app, pilot)
        tableau = app.screen.query_one("#tableau")
        assert app.bench.session.model.problem.model_dump() != before and "margins" in tableau.text.plain
        assert layouts == []

"""What a paint costs (issue 54, section 3): a plot's drawing is turned into cells by Rich,
never converted span by span into Textual's `Content` (27-72 ms for a Bode drawing at
120x40 in a microbench, Rich's render 3-4 ms; on every new figure), with the same cells
as Textual's own conversion draws."""

from __future__ import annotations

from rich.text import Text
from textual.app import App, ComposeResult
from textual.content import Content
from textual.coordinate import Coordinate
from textual.geometry import Region
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


class TablesApp(App):
    """The shaping table beside Textual's `DataTable` with the same rows."""

    def compose(self) -> ComposeResult:
        from textual.widgets import DataTable

        from tui.widgets.shape_table import ShapeTable

        yield ShapeTable(id="shape")
        yield DataTable(cursor_type="row", id="textual")


ROWS = [("K", "gain 7.14178 (17.0753 dB) [K]"), ("zero1", "zero at 0.710681 rad/s [T1]"), ("pole1", "pole at 5 rad/s")]


def _filled(app: App) -> tuple:
    """The shaping table and Textual's, each filled with ROWS."""
    from textual.widgets import DataTable

    ours, textuals = app.query_one("#shape"), app.query_one("#textual", DataTable)
    ours.fill([(name, text, None) for name, text in ROWS])
    textuals.add_columns("item", "reads")
    for row in ROWS:
        textuals.add_row(*row)
    return ours, textuals


def _table_cells(table) -> list[list[tuple[str, object, object, bool]]]:
    width, height = table.size
    return [_cells(strip) for strip in table.render_lines(Region(0, 0, width, height))]


@synchronous
async def test_the_shaping_table_draws_the_cells_textuals_table_draws_and_a_nudge_one_row():
    """The shaping table draws its own lines (a `DataTable` re-rendered its header and every
    row on any cell's update: 7-11 ms of a nudge's first paint): the same cells as Textual's
    table with the same rows, its cursor focused or not, after a reading changed in place;
    and a reading changed draws that row again, no other."""
    from rich.console import Console
    from textual.renderables.styled import Styled

    app = TablesApp()
    async with app.run_test(size=(80, 12)) as pilot:
        ours, textuals = _filled(app)
        for focus, row in ((False, 1), (True, 1), (True, 2)):
            ours.move_cursor(row=row)
            textuals.move_cursor(row=row)
            drawn = {}
            for table in (ours, textuals):
                app.set_focus(table if focus else None)
                await pilot.pause()
                drawn[table] = _table_cells(table)
            assert drawn[ours] == drawn[textuals]
        app.set_focus(None)
        await pilot.pause()
        drawn = []
        render_lines = Console.render_lines

        def counted(console, *args, **kwargs):
            if isinstance(args[0], Styled):  # a table's cell
                drawn.append(args[0])
            return render_lines(console, *args, **kwargs)

        Console.render_lines = counted
        try:
            reading = "zero at 0.746215 rad/s [T1]"
            ours.fill([(name, reading if name == "zero1" else text, None) for name, text in ROWS])
            await pilot.pause()
            cells, ours_drawn = _table_cells(ours), len(drawn)
            textuals.update_cell_at(Coordinate(1, 1), reading)
            await pilot.pause()
            assert cells == _table_cells(textuals)
            assert ours_drawn == 2 and len(drawn) - ours_drawn >= 8  # the row's two cells; Textual's: every cell
            drawn.clear()
            _table_cells(ours)
        finally:
            Console.render_lines = render_lines
        assert len(drawn) == 0  # drawn once since the reading changed: kept


@synchronous
async def test_a_column_widened_in_the_shaping_table_lays_out_nothing_unless_a_scroll_bar_comes():
    """A reading longer than any before (a nudge's value with more digits) widens its column:
    the lines are drawn again at the new widths, the cells those of Textual's table widened as
    far, and the screen is laid out only when a scroll bar comes (before, every widening laid
    the screen out: 3 of 20 nudges of the lead's zero at 120x40, where the table scrolls across)."""
    from textual.screen import Screen

    app = TablesApp()
    layouts = []
    refresh_layout = Screen._refresh_layout

    def counted(screen, *args, **kwargs):
        layouts.append(screen._layout_required)
        return refresh_layout(screen, *args, **kwargs)

    def widened(reading: str) -> list:
        return [(name, reading if name == "zero1" else text, None) for name, text in ROWS]

    Screen._refresh_layout = counted
    try:
        async with app.run_test(size=(80, 12)) as pilot:
            ours, textuals = _filled(app)
            app.set_focus(None)
            await pilot.pause()
            layouts.clear()
            reading = "zero at 0.74621538 rad/s (T 1.3401 s) [T1]"  # wider than every reading before
            ours.fill(widened(reading))
            await pilot.pause()
            assert not any(layouts) and ours.widths[1] == len(reading) + 2
            textuals.update_cell_at(Coordinate(1, 1), reading, update_width=True)
            await pilot.pause()
            assert _table_cells(ours) == _table_cells(textuals)
            ours.fill(widened("x" * 90))  # past the room: a scroll bar comes, laid out
            await pilot.pause()
            assert any(layouts) and ours.max_scroll_x == ours.widths[0] + 92 - 80
            layouts.clear()
            ours.fill(widened("x" * 95))  # wider still: the scroll bar follows, nothing laid out
            await pilot.pause()
            assert not any(layouts) and ours.max_scroll_x == ours.widths[0] + 97 - 80
            bar = ours.horizontal_scrollbar
            assert bar.window_virtual_size == sum(ours.widths)
            repainted, refresh = [], bar.refresh
            bar.refresh = lambda *args, **kwargs: repainted.append(args) or refresh(*args, **kwargs)
            ours.fill(widened("y" * 95))  # a reading as wide: the scroll bar is left as it is
            await pilot.pause()
            assert repainted == [] and ours.get_row_at(1)[1] == "y" * 95
    finally:
        Screen._refresh_layout = refresh_layout


class RestyledTablesApp(TablesApp):
    """The two tables, whose cursor turns red with a class (the header and the rows' base kept)."""

    CSS = """
    ShapeTable.alarm > .shape-table--cursor { background: red; }
    DataTable.alarm > .datatable--cursor { background: red; }
    """


@synchronous
async def test_the_shaping_tables_lines_follow_a_change_of_its_cursors_style():
    """A change of the styles (a theme, the CSS, a class) draws the shaping table's lines
    again, as Textual's table does: here the cursor's style alone changes (before, each row's
    strip was kept until its reading, the cursor's row, the focus, the width or the base style
    changed: the old cursor's colours stayed on screen)."""
    app = RestyledTablesApp()
    async with app.run_test(size=(80, 12)) as pilot:
        ours, textuals = _filled(app)
        for table in (ours, textuals):
            table.move_cursor(row=1)
        app.set_focus(None)
        await pilot.pause()
        before = _table_cells(ours)
        assert before == _table_cells(textuals)
        for table in (ours, textuals):
            table.add_class("alarm")
        await pilot.pause()
        after = _table_cells(ours)
        assert after == _table_cells(textuals) != before and after[2][1][2].triplet == (255, 0, 0)


@synchronous
async def test_the_shaping_table_highlights_the_row_under_the_mouse_as_textuals():
    """The row under the mouse is highlighted as in Textual's table (a row cursor's hover:
    the header too), the highlight gone once a key moves the cursor or the mouse leaves
    (lost when the table came to draw its own lines: no row followed the mouse)."""
    app = TablesApp()
    async with app.run_test(size=(80, 12)) as pilot:
        ours, textuals = _filled(app)
        app.set_focus(None)
        await pilot.pause()
        plain = _table_cells(ours)
        for row in (3, 0):  # the third row (under the header), the header
            hovered = []
            for table in (ours, textuals):  # (the mouse over one table has left the other)
                await pilot.hover(table, offset=(4, row))
                await pilot.pause()
                hovered.append(_table_cells(table))
            assert hovered[0] == hovered[1] != plain
        await pilot.hover(ours, offset=(4, 2))
        await pilot.pause()
        assert ours.hover_row == 1
        keyed = []
        for table in (ours, textuals):  # the mouse still over ours: a key hides its row
            table.focus()
            await pilot.press("down")
            await pilot.pause()
            keyed.append(_table_cells(table))
        assert ours.hover_row is None and keyed[0] == keyed[1]


@synchronous
async def test_a_shaping_table_wider_than_its_room_scrolls_as_textuals():
    """Narrower than its readings (an 80x24 terminal's tableau side), the shaping table
    scrolls across, its cells those of Textual's table scrolled as far."""
    app = TablesApp()
    async with app.run_test(size=(30, 14)) as pilot:
        ours, textuals = _filled(app)
        app.set_focus(None)
        for x in (0, 7):
            for table in (ours, textuals):
                table.scroll_to(x=x, animate=False, immediate=True)
            await pilot.pause()
            assert ours.scroll_offset.x == textuals.scroll_offset.x == x
            assert _table_cells(ours) == _table_cells(textuals)
        ours.focus()
        await pilot.press("end")  # as DataTable's home and end: across, the row kept
        assert ours.scroll_offset.x == ours.max_scroll_x > 7 and ours.cursor_row == 0
        await pilot.press("home")
        assert ours.scroll_offset.x == 0


class TextsApp(App):
    """A status line over a plot and a text side by side."""

    CSS = "Horizontal > Vertical { width: 40; } #left { height: 5; }"

    def compose(self) -> ComposeResult:
        from textual.containers import Horizontal, Vertical

        from tui.widgets.textview import TextView

        yield TextView("lead.json *  algorithm slp  Iteration 0  edit: T1 value: 1 -> 0.952381", id="status")
        with Horizontal():
            with Vertical():  # (Textual renders the widgets whose container meets the changed box)
                yield FigurePlot(id="left")
            with Vertical():
                yield TextView("PM 41.2\nGM 12.0\nwc 1.17", id="right")


@synchronous
async def test_a_text_repaints_the_cells_it_changed():
    """A new text repaints each changed line from its first changed cell: the status line's
    edit and the side's values changed, the plot beside them is not rendered (before, the
    status line's whole row was repainted, and the paint, the box around every change, held
    the plot)."""
    from tui.widgets.textview import TextView

    app = TextsApp()
    async with app.run_test(size=(80, 8)) as pilot:
        plot = app.query_one("#left", FigurePlot)
        plot.show(_bode_like())
        await pilot.pause()
        await pilot.pause()
        rendered = []
        render_lines = plot.render_lines

        def noted(crop):
            rendered.append(crop)
            return render_lines(crop)

        plot.render_lines = noted
        status, side = app.query_one("#status", TextView), app.query_one("#right", TextView)
        status.set("lead.json *  algorithm slp  Iteration 0  edit: T1 value: 0.952381 -> 1")
        side.set("PM 42.0\nGM 12.0\nwc 1.21")
        await pilot.pause()
        assert rendered == []  # (an export renders every widget: after)
        screen = app.export_screenshot().replace("&#160;", " ")
        assert "0.952381 -&gt; 1" in screen and "PM 42.0" in screen and "wc 1.21" in screen
        status.set(Text("lead.json", style="bold"))  # shorter, its style changed: the whole line
        side.set("PM 42.0\nGM 12.0")
        await pilot.pause()
        screen = app.export_screenshot().replace("&#160;", " ")
        assert "algorithm" not in screen and "wc 1.21" not in screen and "GM 12.0" in screen


class TableauApp(App):
    """A tableau that keeps its height in its scroll, under a status line that does not."""

    def compose(self) -> ComposeResult:
        from textual.containers import VerticalScroll

        from tui.widgets.textview import TextView

        yield TextView("lead.json", id="status")
        with VerticalScroll():
            yield TextView("PM 41.2\nGM 12.0\nS 0.80", id="tableau", keep_height=True)


@synchronous
async def test_a_tableau_that_loses_a_row_is_painted_before_it_is_laid_out():
    """A design that loses a margin's row (the launch vehicle's stability margins come and go
    as a zero moves): the tableau's new text is painted at the height it had, then laid out
    at its own (before, the layout pass of the whole screen came first: 2 of 14 one-way
    nudges of its zero1); a row more is laid out at once; a text made without
    ``keep_height`` follows its lines at once both ways."""
    from textual.screen import Screen

    from tui.widgets.textview import TextView

    app = TableauApp()
    events = []
    refresh_layout, compositor_refresh = Screen._refresh_layout, Screen._compositor_refresh

    def laid_out(screen, *args, **kwargs):
        events.append("layout")
        return refresh_layout(screen, *args, **kwargs)

    def painted(screen):
        compositor_refresh(screen)
        events.append(("paint", app.query_one("#tableau", TextView).text.plain))

    Screen._refresh_layout, Screen._compositor_refresh = laid_out, painted
    try:
        async with app.run_test(size=(40, 10)) as pilot:
            tableau, status = app.query_one("#tableau", TextView), app.query_one("#status", TextView)
            await pilot.pause()
            events.clear()
            tableau.set("PM 41.5\nGM 12.1")
            for _ in range(3):
                await pilot.pause()
            assert events[0] == ("paint", "PM 41.5\nGM 12.1") and "layout" in events and tableau.size.height == 2
            assert "S 0.80" not in app.export_screenshot().replace("&#160;", " ")
            events.clear()
            tableau.set("PM 41.5\nGM 12.1\nS 0.81\nS 0.92")
            await pilot.pause()
            assert events[0] == "layout" and tableau.size.height == 4
            status.set("lead.json *\nsecond line")
            await pilot.pause()
            events.clear()
            status.set("lead.json *")
            await pilot.pause()
            assert events[0] == "layout" and status.size.height == 1
    finally:
        Screen._refresh_layout, Screen._compositor_refresh = refresh_layout, compositor_refresh


@synchronous
async def test_the_shaping_table_selects_by_click_and_keys():
    """Drawing its own lines, the shaping table keeps DataTable's ways to select a row: a
    click on a row, up and down, ctrl+home and ctrl+end (the header is not a row)."""
    app = TablesApp()
    async with app.run_test(size=(80, 12)) as pilot:
        ours, _ = _filled(app)
        ours.focus()
        await pilot.pause()
        region = ours.content_region
        await pilot.click(offset=(region.x + 3, region.y + 3))  # the third row, under the header
        assert ours.cursor_row == 2 and ours.selected[0] == "pole1"
        await pilot.click(offset=(region.x + 3, region.y))  # the header: no row
        await pilot.press("up")
        assert ours.cursor_row == 1
        await pilot.press("ctrl+home")
        assert ours.selected[0] == "K"
        await pilot.press("ctrl+end", "down")
        assert ours.cursor_row == len(ROWS) - 1


@synchronous
async def test_a_nudges_workers_start_after_its_tableau_is_painted(workdir, monkeypatch):
    """The threads a nudge starts (the plots' figures, the pole lines) start once the new
    tableau is on screen: started in the key's handler, they held the GIL half the time of
    the paint (issue 54, section 3: key to painted tableau 40-48 ms for 13-21 ms of CPU)."""
    from textual.screen import Screen

    from tests.tui.test_app import settle
    from tui.app import LoopcraftApp
    from tui.cli import main

    lead = workdir / "lead.json"
    main(["new", str(lead), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"])
    app = LoopcraftApp(lead)
    painted: list[object] = []  # the tableau's text at each paint of the screen
    compositor_refresh = Screen._compositor_refresh

    def noted(screen):
        compositor_refresh(screen)
        tableau = screen.query_one_optional("#tableau")
        if tableau is not None:
            painted.append(tableau.text)

    monkeypatch.setattr(Screen, "_compositor_refresh", noted)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        screen = app.screen
        screen.query_one("#plots").active = "p-bode"
        await pilot.press("C", "down")
        await settle(app, pilot)
        started: dict[str, bool] = {}  # group -> the tableau on screen when its first worker started
        run_worker = screen.run_worker

        def noting(work, *args, group="default", **kwargs):
            current = screen.query_one("#tableau").text
            started.setdefault(group, bool(painted) and painted[-1] is current)
            return run_worker(work, *args, group=group, **kwargs)

        monkeypatch.setattr(screen, "run_worker", noting)
        shown = screen.query_one("#tableau").text
        await pilot.press("right")
        await settle(app, pilot)
        assert screen.query_one("#tableau").text is not shown and "PM deg" in painted[-1].plain
        assert started == {"figures": True, "poles": True}


@synchronous
async def test_a_nudges_first_paint_holds_the_tableau_not_the_tab_bar(workdir, monkeypatch):
    """The paint that shows a nudge's tableau renders the widgets beside it, not the tab bar:
    the status line, on the screen's top row, is set once that paint is done (in the same
    paint, Textual's box around every change reached from the top row to the tableau, and
    the tab bar's dozen widgets were rendered: lead key to tableau 47.6-50.9 ms of UI-thread
    CPU before, 40.7-44.6 after, alternated at load 3); the status line says the edit once
    settled."""
    from textual.screen import Screen
    from textual.widget import Widget
    from textual.widgets._tabbed_content import ContentTab

    from tests.tui.test_app import settle
    from tui.app import LoopcraftApp
    from tui.cli import main

    lead = workdir / "lead.json"
    main(["new", str(lead), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"])
    app = LoopcraftApp(lead)
    rendered: list[Widget] = []
    first: list[list[Widget]] = []  # what the first paint with the new tableau rendered
    shown: list[object] = [None]  # the tableau's text before the nudge
    compositor_refresh, render_lines = Screen._compositor_refresh, Widget.render_lines

    def noted(screen):
        compositor_refresh(screen)
        tableau = screen.query_one_optional("#tableau")
        if tableau is not None and tableau.text is not shown[0] and not first:
            first.append(list(rendered))
        rendered.clear()

    monkeypatch.setattr(Screen, "_compositor_refresh", noted)
    monkeypatch.setattr(
        Widget, "render_lines", lambda widget, crop: rendered.append(widget) or render_lines(widget, crop)
    )
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C", "down", "right")
        await settle(app, pilot)
        shown[0] = app.screen.query_one("#tableau").text
        first.clear()
        status = app.screen.query_one("#status").text.plain
        await pilot.press("right")
        await settle(app, pilot)
        assert first and app.screen.query_one("#tableau") in first[0]
        assert not any(isinstance(w, ContentTab) for w in first[0])
        now = app.screen.query_one("#status").text.plain
        assert now != status and app.bench.edits.last in now


@synchronous
async def test_a_start_held_for_a_paint_runs_when_another_screen_covers_the_workbench(workdir):
    """A worker's start held for the screen's next paint (`MainScreen.after_paint`) is not
    lost when another screen covers the workbench (a screen, a dialog): the workbench is
    painted beneath it (Textual's background screen), or starts them when covered."""
    from textual.screen import Screen

    from tests.tui.test_app import settle
    from tui.app import LoopcraftApp
    from tui.screens.dialogs import ConfirmDialog

    app = LoopcraftApp(workdir / "cip_launch_vehicle.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        screen, started = app.screen, []
        screen.after_paint(lambda: started.append("held"))
        app.push_screen(Screen())
        app.push_screen(ConfirmDialog("a question?"))  # the workbench no longer painted
        await settle(app, pilot)
        assert started == ["held"]
        screen.after_paint(lambda: started.append("covered"))
        assert started == ["held", "covered"]
        app.pop_screen()
        await settle(app, pilot)
        screen.after_paint(lambda: started.append("beneath a screen"))
        await settle(app, pilot)
        assert started == ["held", "covered", "beneath a screen"]


@synchronous
async def test_a_centred_text_repaints_its_whole_lines():
    """A text laid out other than from the left (centred here) or holding a tab: a changed
    character moves what stands before it on screen, so its lines are repainted whole (a
    repaint from the first changed character left the old cells to its left)."""
    from tui.widgets.textview import TextView

    app = TextsApp()
    async with app.run_test(size=(80, 8)) as pilot:
        status = app.query_one("#status", TextView)
        asked = []
        refresh = status.refresh

        def noted(*regions, **kwargs):
            asked.append(regions)
            return refresh(*regions, **kwargs)

        status.refresh = noted
        for text in (Text("PM 41.2 deg", justify="center"), Text("PM 41.2 deg, GM 12.0 dB", justify="center")):
            status.set(text)
            await pilot.pause()
        status.set("PM\t41.2 deg, GM 12.0 dB")
        await pilot.pause()
        status.set("PM\t41.2 deg, GM 12.5 dB")
        await pilot.pause()
        assert asked and all(regions == () for regions in asked), asked
        status.set("PM 41.2 deg, GM 12.5 dB")
        status.set("PM 41.2 deg, GM 12.0 dB")  # from the left, no tab: from the changed cell on
        assert asked[-1] == (Region(19, 0, status.size.width - 19, 1),)


@synchronous
async def test_the_shaping_tables_header_is_repainted_where_it_stands_when_scrolled():
    """The header stays at the top: a hover on it repaints the table's first line whatever
    the scroll (before, its region was placed as a row's, above the table once scrolled)."""
    from tui.widgets.shape_table import ShapeTable

    app = TablesApp()
    async with app.run_test(size=(80, 8)) as pilot:
        ours, _ = _filled(app)
        ours.fill([(f"item{k}", f"zero at {k} rad/s", None) for k in range(30)])
        ours.styles.height = 5
        await pilot.pause()
        ours.scroll_to(y=5, animate=False, immediate=True)
        await pilot.pause()
        assert ours.scroll_offset.y == 5
        regions: list[Region] = []
        refresh = ShapeTable.refresh

        def noted(self, *asked, **options):
            regions.extend(asked)
            return refresh(self, *asked, **options)

        ShapeTable.refresh = noted
        try:
            ours.hover_row = -1  # the header under the mouse
        finally:
            ShapeTable.refresh = refresh
        assert regions and all(region.y == 0 for region in regions)

"""A figure's text read off plotext's matrices of characters and colours (issue 55, section
2: a third of a drag frame's drawing was building plotext's escape codes and parsing them
back): the same text, spans and styles as rich's `Text.from_ansi` of plotext's canvas, for
every kind of plot the workbench draws, and no escape codes built."""

from __future__ import annotations

from pathlib import Path

import pytest
from rich.text import Text

from sessions.store import load_session
from tui.drawing import text_canvas
from tui.figures.catalog import figures
from tui.figures.closed_loop import locus_figure
from tui.figures.lines import sweep_figure
from tui.state.workbench import Workbench

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
CANVASES = ((71, 17), (60, 9))  # the dragged Bode plot at 120x40; a compact variant


def _every_kind() -> dict[str, object]:
    bench = Workbench(load_session(EXAMPLES / "lead_sensitivity_peak.json"))
    bench.session.path = None  # stepped in memory: no autosave beside the bundled example
    bench.step()
    drawn = {**figures(bench.view()), "locus": locus_figure(bench.view()), "sweep": sweep_figure(None)}
    reactor = Workbench(load_session(EXAMPLES / "projection_reactor.json"))
    reactor.session.path = None
    reactor.step()
    return {**drawn, **{f"reactor {k}": v for k, v in figures(reactor.view()).items()}}


def test_every_plot_kind_s_text_is_rich_s_reading_of_plotext_s_escape_codes(monkeypatch: pytest.MonkeyPatch) -> None:
    kinds = _every_kind()
    assert {"bode-mag", "bode-phase", "nyquist", "nichols", "poles", "step", "locus", "reactor trajectories"} <= set(
        kinds
    )
    for name, figure in kinds.items():
        for width, height in CANVASES:
            with monkeypatch.context() as patched:
                patched.setattr(text_canvas, "canvas_text", lambda plot: Text.from_ansi(plot.build()))
                parsed = text_canvas.draw(figure, width, height, "textual-dark")
            read = text_canvas.draw(figure, width, height, "textual-dark")
            assert (parsed is None) == (read is None), (name, width, height)
            if parsed is None or read is None:
                continue
            assert read.text.plain == parsed.text.plain, (name, width, height)
            assert read.text.spans == parsed.text.spans, (name, width, height)
            assert (read.text.end, read.text.tab_size) == (parsed.text.end, parsed.text.tab_size)
            assert read.frames == parsed.frames and read.legend_rows == parsed.legend_rows


def test_no_escape_codes_are_built_for_a_drawing(monkeypatch: pytest.MonkeyPatch) -> None:
    from plotext._matrix import matrix_class

    built = []
    canvas = matrix_class.set_canvas
    monkeypatch.setattr(matrix_class, "set_canvas", lambda self: built.append(self.rows * self.cols) or canvas(self))
    figure = _every_kind()["bode-mag"]
    assert text_canvas.draw(figure, *CANVASES[0], "textual-dark") is not None
    assert not any(built)  # cells written as escape codes (plotext's empty matrices write none); before: 71 x 17

"""Plots readable at a glance (issue 36, section 4): the legend hides no data, curves
are told apart without colour, tick labels never touch."""

from __future__ import annotations

import asyncio
import re
from dataclasses import replace
from pathlib import Path

import pytest
from textual.widgets import TabbedContent, Tabs

from sessions.store import load_session
from tests.tui.test_app import settle
from tui.app import LoopcraftApp
from tui.drawing import legend
from tui.drawing.text_canvas import COMPACT_ROWS, draw
from tui.figures.catalog import figures
from tui.screens.main import TAB_LABELS, fitted_labels
from tui.state.workbench import Workbench

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
CANVASES = ((118, 30), (100, 20), (78, 12), (78, 7), (60, 9))
THEME = "textual-dark"


def _figures(example: str, steps: int = 1):
    bench = Workbench(load_session(EXAMPLES / f"{example}.json"))
    bench.session.path = None  # stepped in memory: no autosave beside the bundled example
    for _ in range(steps):
        bench.step()
    return figures(bench.view())


def _inside(plain: str, frame) -> list[str]:
    lines = plain.split("\n")
    return [lines[r][frame.left : frame.right + 1] for r in range(frame.top, frame.bottom + 1)]


def _unlabelled(fig):
    return replace(
        fig,
        series=[replace(s, label="") for s in fig.series],
        panels=[_unlabelled(p) for p in fig.panels],
        compact=fig.compact and _unlabelled(fig.compact),
    )


@pytest.mark.parametrize("example", ["lead_sensitivity_peak", "coebra_launch_vehicle", "projection_reactor"])
def test_the_legend_hides_no_point_of_any_curve(example):
    """Each figure's plot is the same with its legend (rows under it) as without one:
    plotext drew its legend over the curves' top-left corner (the step's peak at 120x40)."""
    checked = 0
    for name, fig in _figures(example).items():
        for width, height in CANVASES:
            drawn = draw(fig, width, height, THEME)
            if drawn is None or not drawn.legend_rows:
                continue
            bare = draw(_unlabelled(fig), width, height - drawn.legend_rows, THEME)
            plot = drawn.text.plain.split("\n")[: -drawn.legend_rows]
            assert plot == bare.text.plain.rstrip("\n").split("\n"), (example, name, width, height)
            labels = " ".join(drawn.text.plain.split("\n")[-drawn.legend_rows :])
            variant = fig.compact if fig.compact is not None and height < COMPACT_ROWS else fig
            assert legend.entries(variant)[0].label[:8] in labels, (name, labels)
            checked += 1
    assert checked >= 10


def test_curves_of_each_role_are_told_apart_without_colour():
    """Current and initial, and each flight condition, have their own legend sample (the
    marker they are drawn with): before, every curve was a braille line told by colour."""
    current_and_initial = _figures("lead_sensitivity_peak", steps=2)
    conditions = _figures("coebra_launch_vehicle", steps=1)
    for figs, expected in ((current_and_initial, 2), (conditions, 3)):
        for name in ("nyquist", "bode-mag", "nichols", "step"):
            curves = [e for e in legend.entries(figs[name]) if len(e.sample) == 2 and " target: " not in e.label]
            samples = [e.sample for e in curves]
            assert len(samples) >= expected and len(set(samples)) == len(samples), (name, curves)


def _tick_rows(plain: str, frame) -> list[int]:
    lines = plain.split("\n")
    return [r for r in range(frame.top, frame.bottom + 1) if lines[r][frame.left - 1] == "┤"]


@pytest.mark.parametrize("example", ["lead_sensitivity_peak", "seidel_inlet_pid", "projection_reactor"])
def test_tick_labels_have_a_blank_row_or_column_between_them(example):
    """Y labels on consecutive rows (100/50/0/-100 on a four-row Bode) and x labels run
    together ('0.010.1') at small canvases; each x label must read as one tick."""
    for name, fig in _figures(example).items():
        for width, height in CANVASES:
            drawn = draw(fig, width, height, THEME)
            if drawn is None:
                continue
            lines = drawn.text.plain.split("\n")
            for frame in drawn.frames:
                rows = _tick_rows(drawn.text.plain, frame)
                assert all(b - a >= 2 for a, b in zip(rows, rows[1:])), (example, name, width, height, rows)
                if "┬" in lines[frame.bottom + 1]:
                    values = [_value(word) for word in lines[frame.bottom + 2].split() if word not in ("h", "s")]
                    assert all(b > a for a, b in zip(values, values[1:])), (example, name, width, height, values)


SUFFIX = {"n": 1e-9, "µ": 1e-6, "m": 1e-3, "k": 1e3, "M": 1e6, "G": 1e9}


def _value(word: str) -> float:
    """A tick label's value; two labels run together ('0.010.1') do not read as one."""
    match = re.fullmatch(r"(-?\d+(?:\.\d+)?(?:e[-+]?\d+)?)([nµmkMG]?)", word)
    assert match, word
    return float(match[1]) * SUFFIX.get(match[2], 1.0)


def test_a_legend_entry_is_shown_whole_or_counted():
    """An entry that does not fit beside others is counted ("+1"), never cut ("S >= 0.505 tar…"
    at 80x24); one alone on its row, wider than the row, is cut."""
    found = [legend.Entry("⠒⠒", "current", None), legend.Entry("x", "-1", None)]
    found.append(legend.Entry("••", "S >= 0.505 target: NOT met", None))
    whole = [e.sample + " " + e.label for e in found]
    assert [r.plain for r in legend.rows(found, 36, 2)] == ["  ".join(whole[:2]), whole[2]]
    assert [r.plain for r in legend.rows(found, 36, 1)] == ["  ".join(whole[:2]) + " +1"]
    assert [r.plain for r in legend.rows(found, 18, 1)] == [whole[0] + " +2"]  # "x -1" too: " +1" did not fit
    assert [r.plain for r in legend.rows(found[2:], 12, 1)] == [whole[2][:11] + "…"]
    for width in range(8, 60):
        for most in (1, 2):
            drawn = legend.rows(found, width, most)
            assert len(drawn) <= most and all(r.cell_len <= width for r in drawn), (width, most)
            for row in drawn:
                parts = re.sub(r" \+\d+$", "", row.plain).split("  ")
                assert all(p in whole for p in parts) or (len(parts) == 1 and parts[0].endswith("…")), row


@pytest.mark.parametrize("size", [(80, 24), (120, 40)], ids=["80x24", "120x40"])
@pytest.mark.parametrize("example", ["lead_sensitivity_peak", "cip_launch_vehicle"])  # eight plot tabs, six
def test_every_plot_tab_label_is_whole_in_the_strip(example, size, workdir):
    """The plot tabs' strip shows each label whole (at 80x24 "Converg" was cut at its edge):
    shortened where it is narrow, the full names where they fit."""

    async def check() -> None:
        app = LoopcraftApp(workdir / f"{example}.json")
        async with app.run_test(size=size) as pilot:
            await settle(app, pilot)
            plots = app.screen.query_one("#plots", TabbedContent)
            strip = plots.query_one(Tabs).region
            for pane in app.screen.plot_tabs:
                tab = plots.get_tab(pane)
                assert strip.contains_region(tab.region), (pane, tab.region, strip)
                assert tab.label_text in TAB_LABELS[pane] and tab.content_region.width >= len(tab.label_text)
            shown = [plots.get_tab(pane).label_text for pane in app.screen.plot_tabs]
            assert (shown == [TAB_LABELS[pane][0] for pane in app.screen.plot_tabs]) == (size == (120, 40))

    asyncio.run(check())


def test_the_plot_tab_labels_shortened_are_the_longest_first():
    tabs = ["p-nyquist", "p-bode", "p-nichols", "p-closed", "p-convergence", "p-step"]
    full = [TAB_LABELS[tab][0] for tab in tabs]
    assert fitted_labels(tabs, sum(len(label) + 2 for label in full)) == (full, False)
    assert fitted_labels(tabs, 37) == (["Nyquist", "Bode", "Nichols", "S/T", "Conv", "Step"], True)
    assert fitted_labels(tabs, 30) == (["Nyq", "Bode", "Nich", "S/T", "Conv", "Step"], True)

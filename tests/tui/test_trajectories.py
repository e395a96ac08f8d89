"""The Trajectories plot of projection sessions: report 004's reactor gets the bounded input
against its bound and the untrimmed open loop, and the trim inputs apart; the others keep
the plain plot of every control."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sessions.store import load_session
from tui.drawing.text_canvas import COMPACT_ROWS
from tui.figures.trajectories import axis, short, time_ticks, trajectories_figure
from tui.state.workbench import Workbench
from tui.widgets.plots import FigurePlot


def stepped(workdir, name: str, steps: int) -> Workbench:
    bench = Workbench(load_session(workdir / name))
    for _ in range(steps):
        bench.step()
    return bench


def figure_of(bench: Workbench):
    return trajectories_figure(bench.view().trajectories(), bench.session.problem.objective.data)


def by_label(panel) -> dict:
    return {s.label: s for s in panel.series if s.label}


def test_the_reactor_plots_u2_its_bound_and_the_open_loop_then_the_trims(workdir):
    bench = stepped(workdir, "projection_reactor.json", 3)
    fig = figure_of(bench)
    top, bottom = fig.panels
    current, initial = bench.records[-1].extra, bench.records[0].extra["open_loop"]
    assert initial["zero_inputs"] == [6, 7]  # numbers from 1: u6, u7
    series = by_label(top)
    assert list(series) == ["bound ±4e13", "initial (untrimmed)", "u2"]
    assert series["u2"].y == pytest.approx(np.array(current["u"])[:, 1].tolist())
    assert series["initial (untrimmed)"].y == pytest.approx(np.array(initial["u"])[:, 1].tolist())
    assert series["initial (untrimmed)"].color == "gray"
    assert sorted(s.y[0] for s in top.series if s.color == "red") == [-4e13, 4e13]
    assert series["u2"].x[-1] == pytest.approx(40.0) and bottom.xlabel == "t (h)"  # 144000 s in hours
    assert top.title == "u2: untrimmed peak -5.46e14 at 36 h"  # off the cut axis
    assert top.ylim == pytest.approx((-8.8e13, 8.8e13)) and 4e13 in top.yticks[0]
    assert top.xticks == ([], []) and bottom.xticks[1][-1] == "40"
    trims = by_label(bottom)
    assert list(trims) == ["u6", "u7"]
    assert trims["u7"].y == pytest.approx(np.array(current["u"])[:, 6].tolist())
    assert max(abs(v) for v in trims["u6"].y) < 1e-2 * 4e13  # why it has its own axis
    assert bottom.ylim[1] < 1e12


def test_the_compact_variant_keeps_the_open_loop_label_and_puts_the_unit_on_a_tick(workdir):
    fig = figure_of(stepped(workdir, "projection_reactor.json", 3)).compact
    top, bottom = fig.panels
    assert list(by_label(top)) == ["initial (untrimmed)"] and list(by_label(bottom)) == ["u6", "u7"]
    assert bottom.xlabel == "" and bottom.xticks[1][-1] == "40 h"


def test_iteration_0_has_the_open_loop_in_the_initial_record(workdir):
    bench = stepped(workdir, "projection_reactor.json", 0)
    fig = figure_of(bench)  # no records yet: iteration 0's
    assert len(fig.panels) == 2 and "initial (untrimmed)" in by_label(fig.panels[0])


def test_seconds_without_time_unit_and_inputs_by_name(workdir):
    bench = stepped(workdir, "projection_reactor.json", 1)
    record = bench.records[0]
    data = {k: v for k, v in bench.session.problem.objective.data.items() if k != "time_unit"}
    named = dict(record.extra, open_loop=dict(record.extra["open_loop"], zero_inputs=["u6", "u7"]))
    view = dataclasses.replace(bench.view(), records=(dataclasses.replace(record, extra=named),))
    fig = trajectories_figure(view.trajectories(), data)
    assert fig.panels[-1].xlabel == "t (s)" and fig.panels[0].series[-1].x[-1] == pytest.approx(144000.0)
    assert list(by_label(fig.panels[1])) == ["u6", "u7"]
    assert fig.panels[0].title.endswith("at 1.3e5 s")


@pytest.mark.parametrize("name", ["projection_integrator.json", "projection_hyperplane.json"])
def test_sessions_without_an_open_loop_keep_the_plot_of_every_control(workdir, name):
    bench = stepped(workdir, name, 1)
    fig = figure_of(bench)
    assert fig == trajectories_figure(bench.view().trajectories())
    assert not fig.panels and fig.title == "Controls u(t)"
    assert [s.label for s in fig.series] == [f"u{j + 1}" for j in range(len(bench.view().trajectories()["u"][0]))]


def test_both_panels_are_drawn_at_the_workbench_sizes(workdir):
    fig = figure_of(stepped(workdir, "projection_reactor.json", 3))
    large = FigurePlot.prebuild(fig, (72, 34, "textual-dark"))[1].text.plain
    small = FigurePlot.prebuild(fig, (48, COMPACT_ROWS - 6, "textual-dark"))[1].text.plain
    for text in (large, small):
        assert "u2: untrimmed peak -5.46e14 at 36 h" in text and "Trim inputs u6, u7" in text
        assert "initial (untrimmed)" in text and "-4e13┤" in text and "2e11┤" in text
    assert "t (h)" in large and "bound ±4e13" in large and "40 h" in small and "bound" not in small


def test_ticks():
    assert [short(v) for v in (4e13, -5.4647e14, 0.25, 0.0, 36.0)] == ["4e13", "-5.46e14", "0.25", "0", "36"]
    (lo, hi), (ticks, labels) = axis(-8e13, 8e13, marks=[-4e13, 4e13])
    assert lo < -8e13 and hi > 8e13 and labels == ["-4e13", "0", "4e13"]
    assert time_ticks(0.0, 40.0, "h") == ([0.0, 10.0, 20.0, 30.0, 40.0], ["0", "10", "20", "30", "40 h"])

"""The Sweep tab shows a tolerance study (issue 41, section 2): the histogram of the
row highlighted, its percentiles, fraction unmet and worst sample in the table; `u`
opens the row's worst sample as the start, and says why it cannot when no sample
finished."""

from __future__ import annotations

import pytest

from sessions.format.schema import SweepModel
from tests.tui.test_app import settle, synchronous
from tests.tui.test_never_stale import stale_plots
from tui.app import LoopcraftApp
from tui.cli import main


def studied(workdir) -> str:
    """The lag-lead with a tolerance study of 30 samples kept in it (run serially, here)."""
    path = workdir / "coebra_lag_lead.json"
    argv = ["sweep", str(path), "--tolerance", "T1=+-10%", "--tolerance", "T2=normal:5%"]
    assert main([*argv, "--samples", "30", "--sampling", "lhs", "--seed", "2", "--serial"]) == 0
    return path


@pytest.mark.long
@synchronous
async def test_the_sweep_tab_shows_the_rows_histogram_and_u_opens_its_worst_sample(workdir, capsys):
    app = LoopcraftApp(studied(workdir))
    capsys.readouterr()
    async with app.run_test(size=(160, 45)) as pilot:
        await settle(app, pilot)
        await pilot.press("5")
        await settle(app, pilot)
        sweep = app.bench.sweeps.latest()
        rows = sweep["worst_case"]
        plot, table = app.screen.query_one("#sweep-plot"), app.screen.query_one("#optima-table")
        assert plot.shown.title.startswith(f"{rows[0]['name']} at nominal: ")
        assert [str(c.label) for c in table.columns.values()][5:11] == [
            "unmet % [95 %]",
            "p1",
            "p5",
            "p50",
            "p95",
            "p99",
        ]
        k = next(k for k, r in enumerate(rows) if r["worst_sample"] != rows[0]["worst_sample"])
        table.move_cursor(row=k)
        await settle(app, pilot)
        row = rows[k]
        assert plot.shown.title.startswith(f"{row['name']} at nominal: {100 * row['unmet_fraction']:.1f} % unmet")
        outline = plot.shown.series[0]
        assert max(outline.y) == max(row["histogram"]["counts"]) and outline.x[0] == row["histogram"]["edges"][0]
        assert "the highlighted row's histogram" in str(app.screen.query_one("#sweep-status").render())
        await pilot.press("u")
        await settle(app, pilot)
        values = app.bench.session.problem.condition_values(0)
        assert {name: values[name] for name in ("T1", "T2")} == row["worst_parameters"]
        assert app.bench.iteration == 0 and app.bench.dirty
        assert await stale_plots(app, pilot) == []  # every plot shows the sample's loop
        await pilot.press("ctrl+z")  # one edit: undone in one step
        await settle(app, pilot)
        assert app.bench.session.problem.condition_values(0)["T1"] == 10.0


@synchronous
async def test_u_says_why_it_cannot_open_a_sample_when_none_finished(workdir):
    app = LoopcraftApp(workdir / "coebra_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert app.check_action("use_best", ()) is None and app.key_reason("use_best") == "no sweep yet (w starts one)"
        app.bench.session.model.sweeps.append(
            SweepModel(version=2, kind="tolerance", created="x", algorithm=app.bench.algorithm_name)
        )
        assert app.check_action("use_best", ()) is None
        assert app.key_reason("use_best") == "no sample of the tolerance study finished"
        app.refresh_workbench()
        await pilot.press("5")
        await settle(app, pilot)
        assert app.screen.query_one("#sweep-plot").shown.empty_message == "no sample of the tolerance study finished"


def test_the_histogram_s_compact_variant_fits_a_short_plot():
    """At 80x24 (a plot under `COMPACT_ROWS`) the histogram's title leaves out the interval and its
    axis names the measure alone: both were cut ("WC1 at nominal: 0.0 % unmet (95 %:…")."""
    from tui.figures.lines import histogram_figure

    histogram = {"edges": [20.0, 21.0, 22.0], "counts": [4, 6], "below": 0, "above": 0}
    row = {"name": "WC1", "kind": "crossover_frequency", "condition": "nominal", "unmet_fraction": 0.0}
    row |= {"unmet_interval": [0.0, 0.116], "histogram": histogram, "desired": 10.0, "unmet_samples": 0}
    fig = histogram_figure(row)
    assert fig.title == "WC1 at nominal: 0.0 % unmet (95 %: 0.0-11.6 %)"
    assert fig.xlabel == "WC1 (crossover_frequency) at nominal; desired 10 <-"
    assert (fig.compact.title, fig.compact.xlabel) == ("WC1 at nominal: 0.0 % unmet", "WC1; desired 10 <-")
    assert fig.compact.series == fig.series and fig.compact.compact is None

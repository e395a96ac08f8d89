"""Figures of lines over time or run: convergence, closed-loop step responses
with their classical marks, and a sweep's runs; a tolerance study's histogram of
one measure at one flight condition (a row of its worst case,
`sessions.sweeps.dispersion`): the counts as bars' outline, the desired value
(green when every sample meets it, red otherwise; beyond the samples, written with
an arrow to its side), the 5th, 50th and 95th percentiles and the worst sample."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from engine.stepping.memory_fields import finite_or_none
from tui.figures.axes import finite_points
from tui.figures.data import Figure, Series, role_style


def line_figure(title: str, xlabel: str, ylabel: str, x: list[float], y: list[float], empty: str) -> Figure:
    fig = Figure(title=title if x else "", xlabel=xlabel, ylabel=ylabel, empty_message=empty)
    if x:
        fig.series.append(Series(list(map(float, x)), list(map(float, y)), ylabel, marker="dot"))
    return fig


def step_figure(name: str, traces: list[tuple[list[float], list[float], str, str]], marks=None) -> Figure:
    """Closed-loop step responses of ``name``: (t, y, label, role) per trace (roles as
    `engine.analysis.LoopCurve`'s, the index its rank), scaled to the current design's
    traces (not a reference's); ``marks`` (the
    current design's `StepMeasures`) adds the settling band, the peak and the
    settling and rise times."""
    fig = Figure(
        xlabel="t (s)",
        ylabel="response",
        empty_message="no step response (needs a rational plant, one with delays, or a table whose fit holds)",
    )
    for index, (t, y, label, role) in enumerate(traces):
        fig.title = f"Step response: {name}"
        fig.series.append(Series(*finite_points(np.array(t), np.array(y)), label, **role_style(role, index)))
    current = [s for s, trace in zip(fig.series, traces) if trace[3] != "reference" and s.y] or [
        s for s in fig.series if s.y
    ]
    if not current:
        return fig
    low, high = min(min(s.y) for s in current), max(max(s.y) for s in current)
    t_end = max(s.x[-1] for s in fig.series if s.x)
    if marks is not None:
        _step_marks(fig, marks, t_end)
        low, high = min(low, marks.final * 0.95), max(high, marks.final * 1.05)
    pad = 0.08 * (high - low) or 0.1 * max(abs(high), 1.0)
    fig.ylim = (low - pad, high + pad)
    return fig


def _step_marks(fig: Figure, m, t_end: float) -> None:
    """The +-5 % band about the final value, the peak, the rise and settling times."""
    band = [m.final * 0.95, m.final * 1.05]
    for level in band:
        fig.series.append(Series([0.0, t_end], [level, level], color="gray", marker="dot"))
    parts = []
    if m.rise_time is not None:
        parts.append(f"rise {m.rise_time:.3g} s")
    if m.peak_time is not None:
        fig.series.append(Series([m.peak_time], [m.peak], "peak", marker="x", scatter=True, color="red"))
        parts.append(f"overshoot {m.overshoot_percent:.3g} %")
    if m.settling_time is not None:
        fig.series.append(Series([m.settling_time] * 2, band, "settled (5 %)", marker="|", color="green"))
        parts.append(f"settles {m.settling_time:.3g} s")
    if parts:
        fig.title += "  " + ", ".join(parts)


def sweep_figure(sweep: dict | None, row: int = 0) -> Figure:
    """A sweep: the final ranking value against the start (starts), the trade-off (vary),
    or, for a tolerance study, the histogram of one row of its worst case (``row``)."""
    fig = Figure(empty_message="no sweep yet: w starts one")
    if not sweep:
        return fig
    if sweep["kind"] == "tolerance":
        rows = sweep["worst_case"]
        if not rows:
            fig.empty_message = "no sample of the tolerance study finished"
            return fig
        return histogram_figure(rows[min(max(row, 0), len(rows) - 1)])
    runs = [r for r in sweep["runs"] if r["status"] != "failed"]
    if sweep["kind"] == "vary" and runs and all("averaged_squares" in r for r in runs):
        squares = [r["averaged_squares"] for r in runs]
        fig.title, fig.xlabel, fig.ylabel = "Trade-off", "output (normalized)", "output rate (normalized)"
        fig.series.append(
            Series(
                [q["x1_normalized"] for q in squares], [q["x1_rate_normalized"] for q in squares], "runs", marker="dot"
            )
        )
        return fig
    fig.title, fig.ylabel = "Final ranking value by start", "ranking"
    name = next((k for r in runs for k in r["start"]), None)
    fig.xlabel = f"start {name} (log10)" if sweep["kind"] == "starts" and name else "run"
    for meets, color in ((True, "green"), (False, "red")):
        chosen = [r for r in runs if r["meets_requirements"] == meets and isinstance(r["ranking"], (int, float))]
        x = [_start_value(r, name) if fig.xlabel != "run" else float(r["index"]) for r in chosen]
        fig.series.append(
            Series(
                x,
                [float(r["ranking"]) for r in chosen],
                "meets every requirement" if meets else "does not",
                marker="dot",
                scatter=True,
                color=color,
            )
        )
    return fig


def _start_value(run: dict, name: str) -> float:
    value = run["start"][name]
    value = value[0] if isinstance(value, list) else value
    return float(np.log10(value)) if value > 0 else float(value)


def histogram_figure(row: dict) -> Figure:
    """The histogram of one worst-case row (empty, saying why, for a row without one)."""
    fig = Figure(empty_message="no distribution kept with this study: run it again")
    histogram = row.get("histogram")
    if not histogram or not histogram["counts"]:
        if histogram:
            fig.empty_message = "no finite value to draw (every sample infinite or undefined)"
        return fig
    edges, counts = histogram["edges"], histogram["counts"]
    fig.title = _histogram_title(row)
    fig.xlabel, fig.ylabel = f"{row['name']} ({row['kind']}) at {row['condition']}", "samples"
    fig.series.append(Series(*_outline(edges, counts), "samples", marker="braille", color="blue"))
    top = max(counts) * 1.1 or 1.0
    fig.ylim = (0.0, top)
    _histogram_marks(fig, row, top, (edges[0], edges[-1]))
    long_name = f"{row['name']} ({row['kind']}) at {row['condition']}"
    # on a short canvas (80x24) the title without its interval, the axis by the measure's name
    fig.compact = replace(
        fig, title=_histogram_title(row, interval=False), xlabel=fig.xlabel.replace(long_name, row["name"])
    )
    return fig


def _histogram_title(row: dict, interval: bool = True) -> str:
    low, high = row["unmet_interval"]
    histogram = row["histogram"]
    off = [f"{n} at {sign}inf" for n, sign in ((histogram["below"], "-"), (histogram["above"], "+")) if n]
    off += [f"{row['undefined']} undefined"] if row.get("undefined") else []
    return (
        f"{row['name']} at {row['condition']}: {100 * row['unmet_fraction']:.1f} % unmet"
        + (f" (95 %: {100 * low:.1f}-{100 * high:.1f} %)" if interval else "")
        + "".join(f", {text}" for text in off)
    )


def _outline(edges: list[float], counts: list[int]) -> tuple[list[float], list[float]]:
    """The bars' outline: up each bar's left edge, across its top, down at the last one's right."""
    x, y = [float(edges[0])], [0.0]
    for k, count in enumerate(counts):
        x += [float(edges[k]), float(edges[k + 1])]
        y += [float(count), float(count)]
    return x + [float(edges[-1])], y + [0.0]


def _histogram_marks(fig: Figure, row: dict, top: float, span: tuple[float, float]) -> None:
    """The desired value (when within the drawn span), the percentiles and the worst sample."""
    desired = finite_or_none(row.get("desired"))
    if desired is not None and span[0] <= desired <= span[1]:
        met = row["unmet_samples"] == 0
        fig.series.append(Series([desired] * 2, [0.0, top], "desired", marker="|", color="green" if met else "red"))
    elif desired is not None:  # the histogram keeps its scale: where the desired value lies is written
        fig.xlabel += f"; desired {desired:.4g} " + ("->" if desired > span[1] else "<-")
    shown = [(key, finite_or_none(row.get("percentiles", {}).get(key))) for key in ("p5", "p50", "p95")]
    shown = [(key, value) for key, value in shown if value is not None]
    if shown:
        label = "5th, 50th, 95th percentiles"
        fig.series.append(Series([v for _, v in shown], [top * 0.95] * len(shown), label, marker="+", scatter=True))
    worst = finite_or_none(row.get("worst"))
    if worst is not None:
        label = f"worst: sample {row['worst_sample']}"
        fig.series.append(Series([worst], [top * 0.95], label, marker="x", scatter=True, color="red"))

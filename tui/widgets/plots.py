"""The text plots (the only module that touches plotext).

Each plot keeps plain lists of its series and redraws from them inside
`render` (plotext's `build` rewrites stored data, so a redraw from stored
figure state could lie).  Log-frequency axes are drawn as log10(omega) on a
linear axis with decade labels, never with plotext's log scale.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from rich.text import Text
from textual.binding import Binding
from textual_plotext import PlotextPlot
from textual_plotext.plot import Plot

from tui.keys import identified
from tui.figures.data import Figure, Series  # noqa: F401 - the figures' data, re-exported for the figure modules
from tui.figures.navigation import Navigation, xy_probe

COMPACT_ROWS = 24


class FigurePlot(PlotextPlot):
    """A plot drawn from a `Figure`.  `show` draws on the next render;
    `prebuild` (any thread) draws into text that `show` can hand over, so a
    worker thread can take the drawing off the UI thread.  Focused, it zooms,
    pans and moves a cursor along the current curve (`navigation`)."""

    can_focus = True
    BINDINGS = identified("plot", [
        Binding("plus,equals_sign", "zoom(1.5)", "zoom in", tooltip="zoom in (about the cursor)", id="plot.zoom_in"),
        Binding("minus", "zoom(0.6666666666666666)", "zoom out", id="plot.zoom_out"),
        Binding("left", "cursor(-1)", "cursor", id="plot.cursor_left",
                tooltip="the cursor along the curve (Poles: pole to pole, zeta, wn)"),
        Binding("right", "cursor(1)", "cursor", show=False, id="plot.cursor_right"),
        Binding("shift+left", "cursor(-10)", "", show=False, id="plot.cursor_left_10"),
        Binding("shift+right", "cursor(10)", "", show=False, id="plot.cursor_right_10"),
        Binding("h", "pan(-0.25, 0)", "pan", tooltip="pan: h j k l", id="plot.pan_left"),
        Binding("l", "pan(0.25, 0)", "", show=False, id="plot.pan_right"),
        Binding("k", "pan(0, 0.25)", "", show=False, id="plot.pan_up"),
        Binding("j", "pan(0, -0.25)", "", show=False, id="plot.pan_down"),
        Binding("0", "reset_view", "reset", tooltip="the whole plot, no cursor")])

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.figure = Figure()
        self.navigation = Navigation()
        self._prebuilt: tuple[tuple[int, int, str], Text] | None = None

    def action_zoom(self, factor: float) -> None:
        self.navigation.zoom(self.figure, factor)
        self.refresh()

    def action_pan(self, dx: float, dy: float) -> None:
        self.navigation.pan(self.figure, dx, dy)
        self.refresh()

    def action_cursor(self, step: int) -> None:
        self.navigation.move(self.figure, step)
        self.refresh()

    def action_reset_view(self) -> None:
        self.navigation.reset()
        self.refresh()

    def on_mouse_scroll_up(self, event) -> None:
        self.action_zoom(1.25)

    def on_mouse_scroll_down(self, event) -> None:
        self.action_zoom(0.8)

    @property
    def shown(self) -> Figure:
        """The figure as drawn: zoomed, with the cursor (`navigation`)."""
        return self.navigation.applied(self.figure)

    def show(self, figure: Figure, prebuilt: tuple[tuple[int, int, str], Text] | None = None) -> None:
        if figure.probe is None:   # a cursor on any plot: along its first curve
            first = next((s for s in figure.series if s.x and not s.scatter), None)
            if first is not None:
                figure.probe = xy_probe(first, figure.xlabel or "x", figure.ylabel or "y")
        self.figure, self._prebuilt = figure, prebuilt
        self.refresh()

    def canvas(self) -> tuple[int, int, str]:
        """(width, height, plotext theme) of the next render."""
        return self.size.width, self.size.height, self._get_plotext_theme_name(self.app.theme)

    @staticmethod
    def prebuild(figure: Figure, canvas: tuple[int, int, str]) -> tuple[tuple[int, int, str], Text] | None:
        width, height, theme = canvas
        if width < 10 or height < 5:
            return None
        plot = Plot()
        _draw(plot, figure, height, width)
        plot.plotsize(width, height)
        plot._set_size(width, height)
        plot.theme(theme)
        try:
            return canvas, Text.from_ansi(plot.build())
        except (IndexError, ValueError, ZeroDivisionError, OverflowError):
            return None

    def render(self):
        figure = self.shown
        if self._prebuilt is not None and self._prebuilt[0] == self.canvas() and figure is self.figure:
            return self._prebuilt[1]
        _draw(self.plt, figure, self.size.height, self.size.width)
        try:
            return super().render()
        except (IndexError, ValueError, ZeroDivisionError, OverflowError) as exc:   # a tiny canvas, odd values
            return f"{self.figure.title}: cannot draw at this size ({type(exc).__name__})"


def _draw(plt, fig: Figure, height: int | None = None, width: int | None = None) -> None:
    """Clear ``plt`` and draw ``fig`` on it (its panels as subplots in one column; its compact
    variant when the canvas is shorter than COMPACT_ROWS; its title and x label cut to the
    ``width``)."""
    if fig.compact is not None and height is not None and height < COMPACT_ROWS:
        fig = fig.compact
    plt.clear_figure()
    if fig.panels:
        plt.subplots(len(fig.panels), 1)
        for row, panel in enumerate(fig.panels, start=1):
            _draw_one(plt.subplot(row, 1), panel, width)
        plt.main()
        return
    _draw_one(plt, fig, width)


def _draw_one(plt, fig: Figure, width: int | None = None) -> None:
    """Draw ``fig`` on a cleared plot or subplot (``width`` wide: the labels cut to fit)."""
    title, xlabel = fig.title or fig.empty_message, fig.xlabel
    if width is not None:
        title, xlabel = _fitted(fig, title, xlabel, width)
    plt.title(title)
    if xlabel:
        plt.xlabel(xlabel)
    if fig.ylabel:
        plt.ylabel(fig.ylabel)
    for s in fig.series:
        if not s.x:
            continue
        draw = plt.scatter if s.scatter else plt.plot
        kwargs = {"marker": s.marker, "label": s.label or None}
        if s.color:
            kwargs["color"] = s.color
        draw(_near(s.x, fig.xlim), _near(s.y, fig.ylim), **kwargs)
    if fig.xlim:
        plt.xlim(*fig.xlim)
    if fig.ylim:
        plt.ylim(*fig.ylim)
    if fig.xticks is not None:    # ([], []): no time ticks (a panel above another)
        plt.xticks(*fig.xticks)
    elif (span := _span(fig, "x")) is not None:
        plt.xticks(*nice_ticks(*span))
    if fig.yticks:
        plt.yticks(*fig.yticks)
    elif (span := _span(fig, "y")) is not None:
        plt.yticks(*nice_ticks(*span))


def _fitted(fig: Figure, title: str, xlabel: str, width: int) -> tuple[str, str]:
    """The title and x label cut (with an ellipsis) to the room plotext gives them about the
    canvas centre (it drops a label that does not fit); the y tick labels' width estimated."""
    span = _span(fig, "y")
    labels = fig.yticks[1] if fig.yticks else nice_ticks(*span)[1] if span else []
    start = max((len(label) for label in labels), default=1) + 1
    centre = start + (width - start - 1) // 2
    right = width - centre
    room_title = 2 * right - 2
    room_x = min(2 * (centre - len(fig.ylabel) - 1), 2 * right) - 2

    def cut(text: str, room: int) -> str:
        return text if len(text) <= room else text[:max(room - 1, 0)].rstrip() + "…"
    return cut(title, room_title), cut(xlabel, room_x) if xlabel else xlabel


def _span(fig: Figure, axis: str) -> tuple[float, float] | None:
    """The axis's shown range: its limits, else the finite data's extent (None: no data)."""
    limits = fig.xlim if axis == "x" else fig.ylim
    if limits:
        return limits
    values = [v for s in fig.series for v in (s.x if axis == "x" else s.y)
              if math.isfinite(v) and abs(v) < PLOTTABLE]
    return (min(values), max(values)) if values and max(values) > min(values) else None


def nice_ticks(low: float, high: float, count: int = 5) -> tuple[list[float], list[str]]:
    """Round ticks (1, 2 or 5 times a power of ten apart) inside [low, high]."""
    power = 10.0 ** math.floor(math.log10((high - low) / max(count - 1, 1)))
    candidates = [m * power * scale for scale in (0.1, 1.0, 10.0) for m in (1, 2, 5)]
    step = next(c for c in candidates if math.floor(high / c) - math.ceil(low / c) + 1 <= count + 1)
    first = math.ceil(low / step) * step
    ticks = [round(first / step + k) * step for k in range(int((high - first) / step + 1e-9) + 1)]
    digits = max(0, -math.floor(math.log10(step) + 1e-12))
    return ticks, [f"{t:.{digits}f}" if abs(t) < 1e6 and digits <= 6 else f"{t:.3g}" for t in ticks]


PLOTTABLE = 1e150   # plotext's arithmetic on the canvas overflows near the float limits


def _near(values: list[float], limits: tuple[float, float] | None) -> list[float]:
    """Values clipped to a few spans about the axis limits (plotext draws a line point by
    point across the canvas, so a point 1e23 spans off the axis would exhaust memory),
    and always to +-PLOTTABLE."""
    low, high = -PLOTTABLE, PLOTTABLE
    if limits and all(math.isfinite(v) for v in limits):
        span = max(abs(limits[1] - limits[0]), 1e-300)
        low, high = max(low, limits[0] - 2 * span), min(high, limits[1] + 2 * span)
    return np.clip(np.asarray(values, dtype=float), low, high).tolist()


MAX_POINTS = 600   # a text canvas resolves fewer; more only slows plotext down


def _finite(x: np.ndarray, y: np.ndarray) -> tuple[list[float], list[float]]:
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    if x.size > MAX_POINTS:
        step = int(np.ceil(x.size / MAX_POINTS))
        x, y = np.concatenate([x[::step], x[-1:]]), np.concatenate([y[::step], y[-1:]])
    return x.tolist(), y.tolist()


def _decades(log_w: np.ndarray, unit: str) -> tuple[list[float], list[str]]:
    lo, hi = math.floor(np.nanmin(log_w)), math.ceil(np.nanmax(log_w))
    ticks = list(range(lo, hi + 1))
    return [float(t) for t in ticks], [f"{10.0 ** t:g}" for t in ticks]


def line_figure(title: str, xlabel: str, ylabel: str, x: list[float], y: list[float], empty: str) -> Figure:
    fig = Figure(title=title if x else "", xlabel=xlabel, ylabel=ylabel, empty_message=empty)
    if x:
        fig.series.append(Series(list(map(float, x)), list(map(float, y)), ylabel, marker="dot"))
    return fig


def trajectories_figure(data: Mapping | None, system: Mapping | None = None) -> Figure:
    """Controls u_j(t) of the current iterate, from a presenter's trajectories
    ({"t", "x", "u", "current"} and maybe "open_loop"); with the untrimmed open
    loop (report 004's reactor), `projection_figure`'s two panels instead."""
    if data is not None and data.get("open_loop") is not None:
        from tui.figures.trajectories import projection_figure   # here: that module builds on this one's Figure
        figure = projection_figure(data["current"], data["open_loop"], system or {})
        if figure.panels:
            return figure
    fig = Figure(xlabel="t", ylabel="u", empty_message="no trajectories (projection sessions have them)")
    if data is None:
        return fig
    fig.title = "Controls u(t)"
    columns = np.array(data["u"], dtype=float)
    for j in range(columns.shape[1]):
        fig.series.append(Series(list(map(float, data["t"])), columns[:, j].tolist(), f"u{j + 1}"))
    return fig


def step_figure(name: str, traces: list[tuple[list[float], list[float], str, str]], marks=None,
                reference_color: str = "gray") -> Figure:
    """Closed-loop step responses of ``name``: (t, y, label, color) per trace, scaled to
    the current design's traces (not the ``reference_color`` one); ``marks`` (the
    current design's `StepMeasures`) adds the settling band, the peak and the
    settling and rise times."""
    fig = Figure(xlabel="t (s)", ylabel="response", empty_message="no step response (needs a rational plant)")
    for t, y, label, color in traces:
        fig.title = f"Step response: {name}"
        fig.series.append(Series(*_finite(np.array(t), np.array(y)), label, color=color))
    current = [s for s, trace in zip(fig.series, traces) if trace[3] != reference_color and s.y] or \
        [s for s in fig.series if s.y]
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


def sweep_figure(sweep: dict | None) -> Figure:
    """A sweep: final objective against the start (starts), the trade-off (vary),
    or, for a tolerance study, the samples' smallest relative slack."""
    fig = Figure(empty_message="no sweep yet: w starts one")
    if not sweep:
        return fig
    runs = [r for r in sweep["runs"] if r["status"] != "failed"]
    if sweep["kind"] == "vary" and runs and all("averaged_squares" in r for r in runs):
        squares = [r["averaged_squares"] for r in runs]
        fig.title, fig.xlabel, fig.ylabel = "Trade-off", "output (normalized)", "output rate (normalized)"
        fig.series.append(Series([q["x1_normalized"] for q in squares], [q["x1_rate_normalized"] for q in squares],
                                 "runs", marker="dot"))
        return fig
    if sweep["kind"] == "tolerance":
        fig.title, fig.xlabel, fig.ylabel = "Tolerance samples", "sample", "unmet measures"
        fig.series.append(Series([float(r["index"]) for r in runs],
                                 [float(sum(not m["satisfied"] for m in r["measures"])) for r in runs], marker="dot",
                                 scatter=True))
        return fig
    fig.title, fig.ylabel = "Final objective by start", "objective"
    name = next((k for r in runs for k in r["start"]), None)
    fig.xlabel = f"start {name} (log10)" if sweep["kind"] == "starts" and name else "run"
    for meets, color in ((True, "green"), (False, "red")):
        chosen = [r for r in runs if r["meets_requirements"] == meets and isinstance(r["objective"], (int, float))]
        x = [_start_value(r, name) if fig.xlabel != "run" else float(r["index"]) for r in chosen]
        fig.series.append(Series(x, [float(r["objective"]) for r in chosen],
                                 "meets every requirement" if meets else "does not", marker="dot", scatter=True,
                                 color=color))
    return fig


def _start_value(run: dict, name: str) -> float:
    value = run["start"][name]
    value = value[0] if isinstance(value, list) else value
    return float(np.log10(value)) if value > 0 else float(value)

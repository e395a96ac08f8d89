"""Plotting layers compared on our own figures (issue 36, section 1): the render
time of a frame and correctness under zoom, per layer and canvas size.

Run from the repository root: ``python -m tests.bench.plot_layers [--repeat N]
[--boxes N] [--out plot-layers.json]``.  The figures are the workbench's own
(`tui.figures`), built from a bundled example (report003_disk_margin, its grid
raised to 600 points, after one cip step so a reference curve is drawn beside
the current one): the Bode magnitude and phase (two stacked panels, as the
workbench shows them), the Nyquist plot with its circles, the root locus and
the step response with its bands, on 120x40 and 80x24 character canvases.

Layers (each reported "not installed" when its package is absent here):

1. ``plotext5``: today's, plotext 5 behind textual-plotext (`FigurePlot.prebuild`).
2. ``plotext6``: plotext 6 (a rewrite with a C++ kernel) behind a thin drawing
   function below.  plotext 5 and 6 cannot share a venv, so this bench runs in
   two: /work/main/.venv for 1, a second venv for 2 to 4.
3. ``textual-plot``: textual-plot's native `PlotWidget`, mounted in a headless app;
   a frame is setting the data, its `_render_plot` and every canvas line's strip.
4. ``own-canvas``: a small drawer of our own over textual-hires-canvas (braille
   lines, character markers, dotted series as points, a legend in the emptiest
   corner).

A frame ends in what Textual paints (a Rich `Text` or the canvases' strips).
Zoom: ``--boxes`` random zoom/pan boxes per figure and canvas (the same boxes
for every layer), each applied as the workbench does (`Navigation.applied`);
counted are exceptions, "cannot draw" (no output) and blank outputs (a curve
has a sample inside the box but no curve glyph was drawn)."""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import random
import statistics
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "sessions" / "examples" / "report003_disk_margin.json"
CANVASES = ((120, 40), (80, 24))
FIGURES = ("bode", "nyquist", "locus", "step")
THEME = "textual-dark"
# what a drawn curve leaves on the canvas: braille, quadrant and half blocks, plotext's dot
CURVE_GLYPHS = frozenset([chr(c) for c in range(0x2801, 0x2900)] + list("▘▝▀▖▌▞▛▗▚▐▜▄▙▟█•"))
HEX = {"blue": "#4c8eda", "gray": "#8a8a8a", "red": "#e05050", "green": "#50c050", "orange": "#e0a040"}


def build_figures(points: int = 600) -> dict[str, list]:
    """The workbench's figures of the example: name -> panels (drawn one above the other)."""
    from sessions.store import load_session
    from tui.figures.catalog import figures
    from tui.figures.closed_loop import locus_figure
    from tui.state.workbench import Workbench

    session = json.loads(EXAMPLE.read_text())
    session["problem"]["grid"]["points"] = points
    path = Path(tempfile.mkdtemp(prefix="plot-layers-")) / EXAMPLE.name
    path.write_text(json.dumps(session))
    bench = Workbench(load_session(path))
    bench.step()  # a reference (initial) curve beside the current one
    view = bench.view()
    shown = figures(view, only=("nyquist", "bode-mag", "bode-phase", "step"))
    return {
        "bode": [shown["bode-mag"], shown["bode-phase"]],
        "nyquist": [shown["nyquist"]],
        "locus": [locus_figure(view)],
        "step": [shown["step"]],
    }


def split(height: int, count: int) -> list[int]:
    """Rows of ``count`` stacked panels on ``height`` rows (1fr each, as the workbench's CSS)."""
    return [height // count + (1 if k < height % count else 0) for k in range(count)]


def random_box(fig, rng: random.Random) -> tuple[float, float, float, float]:
    """A box a user reaches by zooming and panning: about the data, 1e-4 to 3 times its size."""
    from tui.figures.navigation import data_box

    x0, x1, y0, y1 = data_box(fig)
    w, h = (x1 - x0) * 10 ** rng.uniform(-4, 0.5), (y1 - y0) * 10 ** rng.uniform(-4, 0.5)
    if rng.random() < 0.5:  # zoomed about a sample of a curve (the cursor), else anywhere about the data
        s = rng.choice([s for s in fig.series if s.x] or [None])
        i = rng.randrange(len(s.x)) if s else 0
        cx, cy = (s.x[i], s.y[i]) if s else ((x0 + x1) / 2, (y0 + y1) / 2)
    else:
        cx, cy = (
            rng.uniform(x0 - (x1 - x0) / 2, x1 + (x1 - x0) / 2),
            rng.uniform(y0 - (y1 - y0) / 2, y1 + (y1 - y0) / 2),
        )
    return cx - w / 2, cx + w / 2, cy - h / 2, cy + h / 2


def zoomed(fig, box):
    from tui.figures.navigation import Navigation

    return Navigation(box=box).applied(fig)


def sample_inside(fig) -> bool:
    """Has a line series a finite sample well inside the figure's limits (so a curve must show)?"""
    x0, x1 = fig.xlim
    y0, y1 = fig.ylim
    mx, my = (x1 - x0) * 0.05, (y1 - y0) * 0.05
    for s in fig.series:
        if s.scatter or not s.x:
            continue
        x, y = np.asarray(s.x, dtype=float), np.asarray(s.y, dtype=float)
        if np.any((x > x0 + mx) & (x < x1 - mx) & (y > y0 + my) & (y < y1 - my)):
            return True
    return False


def clipped(values, limits):
    """Values within a few spans of the limits (as tui/widgets/plots.py's `_near` does for plotext 5)."""
    low, high = -1e150, 1e150
    if limits:
        span = max(abs(limits[1] - limits[0]), 1e-300)
        low, high = max(low, limits[0] - 2 * span), min(high, limits[1] + 2 * span)
    return np.clip(np.asarray(values, dtype=float), low, high).tolist()


def ticks(fig, axis: str):
    """The figure's ticks on an axis, else round ones over its limits or data."""
    from tui.figures.axes import nice_ticks

    given = fig.xticks if axis == "x" else fig.yticks
    if given:
        return given
    limits = fig.xlim if axis == "x" else fig.ylim
    if not limits:
        values = [v for s in fig.series for v in (s.x if axis == "x" else s.y) if math.isfinite(v)]
        limits = (min(values), max(values)) if values and max(values) > min(values) else None
    return nice_ticks(*limits) if limits else ([], [])


# ---- layer 1: plotext 5 behind textual-plotext (today's) ----


def plotext5_available() -> str | None:
    try:
        import plotext
        import textual_plotext  # noqa: F401
    except ImportError:
        return "not installed (plotext 5 / textual-plotext absent from this venv)"
    if not plotext.__version__.startswith("5."):
        return f"not installed (plotext {plotext.__version__} here, not 5)"
    return None


def plotext5(fig, width: int, height: int) -> str | None:
    from tui.drawing.text_canvas import draw

    drawing = draw(fig, width, height, THEME)
    return None if drawing is None else drawing.text.plain


# ---- layer 2: plotext 6 behind a thin drawing function ----


def plotext6_available() -> str | None:
    try:
        import plotext
    except ImportError:
        return "not installed (plotext absent from this venv)"
    version = getattr(plotext, "__version__", "0")
    return None if not version.startswith(("5.", "4.")) else f"not installed (plotext {version} here, not 6)"


def plotext6(fig, width: int, height: int) -> str | None:
    import plotext as plt
    from rich.text import Text

    if fig.compact is not None and height < 24:
        fig = fig.compact
    plt.terminal.limit(False, False)  # else the figure is cut to the size of the terminal the process runs in
    f = plt.figure
    f.clear()
    f.plot_size(width, height)
    f.theme("dark")
    f.title(fig.title or fig.empty_message)
    f.label(fig.xlabel or None, 0)
    f.label(fig.ylabel or None, 1)
    for s in fig.series:
        if not s.x:
            continue
        code = {"braille": "braille", "dot": "dot"}.get(s.marker, s.marker if len(s.marker) == 1 else "hd")
        marker = plt.marker(code, plt.pixel(foreground=s.color or "blue"))
        signal = f.signal(clipped(s.x, fig.xlim), clipped(s.y, fig.ylim), marker=marker)
        if not s.scatter and s.marker != "dot":
            signal.lines()
        if s.label:
            signal.label(s.label)
        f.draw(signal)
    for axis, limits in ((0, fig.xlim), (1, fig.ylim)):
        if limits:
            f.ruler(axis).lim(*limits)
        positions, labels = ticks(fig, "x" if axis == 0 else "y")
        if positions:
            f.ruler(axis).ticks(list(positions), list(labels))
    return Text.from_ansi(f.build().string()).plain


# ---- layer 3: textual-plot's PlotWidget ----


def textual_plot_available() -> str | None:
    try:
        import textual_plot  # noqa: F401
    except ImportError:
        return "not installed (textual-plot absent from this venv)"
    return None


class TextualPlotLayer:
    """PlotWidgets of every canvas and panel size, mounted in one headless app."""

    def __init__(self):
        self.widgets: dict[tuple[int, int], object] = {}
        self.app = None

    def sizes(self) -> list[tuple[int, int]]:
        return sorted({(w, r) for w, h in CANVASES for n in (1, 2) for r in split(h, n)}, reverse=True)

    async def start(self):
        from textual.app import App
        from textual.containers import Horizontal, Vertical
        from textual_plot import PlotWidget

        sizes = self.sizes()
        widgets = self.widgets

        class Host(App):
            CSS = "Horizontal { height: auto; } Vertical { width: auto; height: auto; }"

            def compose(self):
                with Horizontal():
                    for width in sorted({w for w, _ in sizes}, reverse=True):
                        with Vertical():
                            for w, h in sizes:
                                if w == width:
                                    plot = PlotWidget()
                                    plot.styles.width, plot.styles.height = w, h
                                    widgets[w, h] = plot
                                    yield plot

        width = sum({w for w, _ in sizes})
        height = max(sum(h for w, h in sizes if w == x) for x in {w for w, _ in sizes})
        self.app = Host()
        self.context = self.app.run_test(size=(width, height))
        self.pilot = await self.context.__aenter__()
        await self.pilot.pause()

    async def stop(self):
        await self.context.__aexit__(None, None, None)

    def render(self, fig, width: int, height: int) -> str | None:
        from textual_hires_canvas import Canvas, HiResMode
        from textual_plot import LegendLocation
        from textual_plot.axis_formatter import NumericAxisFormatter

        plot = self.widgets[width, height]
        plot.clear()
        for s in fig.series:
            if not s.x:
                continue
            style = HEX.get(s.color or "blue", "#4c8eda")  # Rich has no "orange" or "gray"
            if s.scatter:
                plot.scatter(
                    s.x, s.y, marker=s.marker if len(s.marker) == 1 else "o", marker_style=style, label=s.label or None
                )
            elif s.marker == "dot":
                plot.scatter(s.x, s.y, marker_style=style, hires_mode=HiResMode.BRAILLE, label=s.label or None)
            else:
                plot.plot(s.x, s.y, line_style=style, hires_mode=HiResMode.BRAILLE, label=s.label or None)
        plot.set_xlimits(*(fig.xlim or (None, None)))
        plot.set_ylimits(*(fig.ylim or (None, None)))
        if fig.xticks:  # a log frequency axis: the figure's positions, labelled as frequencies

            class Labels(NumericAxisFormatter):
                def get_labels_for_ticks(self, positions):
                    names = dict(zip(fig.xticks[0], fig.xticks[1]))
                    return [names.get(p, f"{p:.3g}") for p in positions]

            plot.set_x_formatter(Labels())
            plot.set_xticks(list(fig.xticks[0]))
        else:
            plot.set_x_formatter(NumericAxisFormatter())
            plot.set_xticks(None)
        plot.set_xlabel(fig.xlabel)
        plot.set_ylabel(fig.ylabel)
        plot.show_legend(LegendLocation.TOPRIGHT, is_visible=any(s.label for s in fig.series))
        plot._render_plot()  # what its render() does when a redraw is due
        rows = []
        for canvas in plot.query(Canvas):
            for y in range(canvas._canvas_size.height):
                canvas.render_line(y)
            if canvas.id == "plot":
                rows = ["".join(r) for r in canvas._buffer]
        return "\n".join(rows)


# ---- layer 4: our own small canvas over textual-hires-canvas ----


def own_canvas_available() -> str | None:
    try:
        import textual_hires_canvas  # noqa: F401
    except ImportError:
        return "not installed (textual-hires-canvas absent from this venv)"
    return None


def _clip_segments(x, y, box):
    """Liang-Barsky: the parts of the segments (x[i], y[i])-(x[i+1], y[i+1]) inside box, as 4 arrays."""
    x0, y0, x1, y1 = x[:-1], y[:-1], x[1:], y[1:]
    keep = np.isfinite(x0) & np.isfinite(y0) & np.isfinite(x1) & np.isfinite(y1)
    x0, y0, x1, y1 = x0[keep], y0[keep], x1[keep], y1[keep]
    dx, dy = x1 - x0, y1 - y0
    t0, t1 = np.zeros_like(x0), np.ones_like(x0)
    with np.errstate(divide="ignore", invalid="ignore"):
        for p, q in ((-dx, x0 - box[0]), (dx, box[1] - x0), (-dy, y0 - box[2]), (dy, box[3] - y0)):
            r = q / p
            t0 = np.where(p < 0, np.maximum(t0, r), t0)
            t1 = np.where(p > 0, np.minimum(t1, r), t1)
            t1 = np.where((p == 0) & (q < 0), -1.0, t1)
    ok = t0 <= t1
    return x0[ok] + t0[ok] * dx[ok], y0[ok] + t0[ok] * dy[ok], x0[ok] + t1[ok] * dx[ok], y0[ok] + t1[ok] * dy[ok]


def own_canvas(fig, width: int, height: int):
    from rich.text import Text
    from textual_hires_canvas import Canvas, HiResMode

    from tui.figures.navigation import data_box

    if fig.compact is not None and height < 24:
        fig = fig.compact
    x0, x1, y0, y1 = data_box(fig)
    (xt, xl), (yt, yl) = ticks(fig, "x"), ticks(fig, "y")
    left = max((len(s) for s in yl), default=1) + 1
    top, right, bottom = 1, width - 1, height - 3  # the plot area's frame: rows top..bottom, columns left..right
    if right - left < 4 or bottom - top < 3:
        return None
    c = Canvas(width, height)
    c.draw_rectangle_box(left, top, right, bottom, thickness=1, style="#808080")
    inner = 1 - 1e-9  # the far limit stays inside the frame
    sx, sy = inner * (right - left - 1) / (x1 - x0), inner * (bottom - top - 1) / (y1 - y0)  # cells per unit

    def col(v):
        return left + 1 + (np.asarray(v) - x0) * sx

    def row(v):
        return top + 1 + (y1 - np.asarray(v)) * sy

    legend = []
    for s in fig.series:
        if not s.x:
            continue
        style = HEX.get(s.color or "blue", "#4c8eda")
        x, y = np.asarray(s.x, dtype=float), np.asarray(s.y, dtype=float)
        if s.scatter:
            inside = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
            glyph = s.marker if len(s.marker) == 1 else "o"
            for cx, cy in zip(col(x[inside]), row(y[inside])):
                c.set_pixel(int(cx), int(cy), glyph, style)
        elif s.marker == "dot":  # a dotted series: its samples alone (told apart from solid curves without colour)
            inside = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
            c.set_hires_pixels(list(zip(col(x[inside]), row(y[inside]))), HiResMode.BRAILLE, style)
            glyph = "⠒"
        if not s.scatter and s.marker != "dot":
            ax, ay, bx, by = _clip_segments(x, y, (x0, x1, y0, y1))
            c.draw_hires_lines(list(zip(col(ax), row(ay), col(bx), row(by))), HiResMode.BRAILLE, style)
            glyph = "⣀"
        if s.label:
            legend.append((glyph, style, s.label))
    for t, label in zip(*(yt, yl)):
        if y0 <= t <= y1:
            c.write_text(left - 1, int(row(t)), label, align=_right())
    for t, label in zip(*(xt, xl)):
        if x0 <= t <= x1:
            at = min(int(col(t)), width - 1 - len(label) // 2)  # the last label kept whole
            c.write_text(at, bottom + 1, label, align=_centre())
    title = fig.title or fig.empty_message
    c.write_text(width // 2, 0, _markup(title[: width - 1]), align=_centre())
    c.write_text(width // 2, height - 1, _markup(f"{fig.xlabel}  [{fig.ylabel}]"[: width - 1]), align=_centre())
    if legend:
        _place_legend(c, legend, (left + 1, top + 1, right - 1, bottom - 1))
    text = Text()
    for chars, styles in zip(c._buffer, c._styles):
        for ch, st in zip(chars, styles):
            text.append(ch, st or None)
        text.append("\n")
    return text.plain


def _right():
    from textual_hires_canvas import TextAlign

    return TextAlign.RIGHT


def _centre():
    from textual_hires_canvas import TextAlign

    return TextAlign.CENTER


def _markup(text: str) -> str:
    from rich.markup import escape

    return escape(text)


def _place_legend(c, entries, area) -> None:
    """The legend in the corner of the plot area where it covers the fewest drawn cells."""
    w = min(max(len(label) for *_, label in entries) + 2, area[2] - area[0] + 1)
    h = min(len(entries), area[3] - area[1] + 1)
    corners = [
        (area[0], area[1]),
        (area[2] - w + 1, area[1]),
        (area[0], area[3] - h + 1),
        (area[2] - w + 1, area[3] - h + 1),
    ]

    def covered(corner):
        cx, cy = corner
        return sum(1 for r in range(cy, cy + h) for k in range(cx, cx + w) if c._buffer[r][k] != " ")

    cx, cy = min(corners, key=covered)
    for k, (glyph, style, label) in enumerate(entries[:h]):
        c.write_text(cx, cy + k, f"[{style}]{glyph}[/] {_markup(label)}")


# ---- the bench ----

LAYERS = {
    "plotext5": (plotext5_available, plotext5),
    "plotext6": (plotext6_available, plotext6),
    "textual-plot": (textual_plot_available, None),
    "own-canvas": (own_canvas_available, own_canvas),
}
PACKAGES = {
    "plotext5": ("plotext", "textual-plotext"),
    "plotext6": ("plotext",),
    "textual-plot": ("textual-plot", "textual-hires-canvas"),
    "own-canvas": ("textual-hires-canvas",),
}


def package_facts(names) -> dict:
    out = {}
    for name in names:
        try:
            meta = metadata.metadata(name)
        except metadata.PackageNotFoundError:
            continue
        out[name] = {"version": meta["Version"], "requires": meta.get_all("Requires-Dist") or []}
    return out


def frame(draw, panels, width: int, height: int):
    """One frame: every panel drawn on its share of the rows; the panels' texts (None: cannot draw)."""
    return [draw(p, width, h) for p, h in zip(panels, split(height, len(panels)))]


def zoom_check(draw, panels, width: int, height: int, boxes: int, seed: str) -> dict:
    rng = random.Random(seed)  # the same boxes for every layer
    errors: dict[str, int] = {}
    cannot, blank, frames, must_show = 0, 0, 0, 0
    for _ in range(boxes):
        for panel, h in zip(panels, split(height, len(panels))):
            shown = zoomed(panel, random_box(panel, rng))
            frames += 1
            inside = sample_inside(shown)
            must_show += inside
            try:
                text = draw(shown, width, h)
            except Exception as exc:  # noqa: BLE001 - counted, that is the measurement
                errors[type(exc).__name__] = errors.get(type(exc).__name__, 0) + 1
                continue
            if text is None:
                cannot += 1
            elif inside and not (set(text) & CURVE_GLYPHS):
                blank += 1
    return {
        "panels_drawn": frames,
        "with_a_sample_inside": must_show,
        "exceptions": sum(errors.values()),
        "exception_types": errors,
        "cannot_draw": cannot,
        "blank": blank,
    }


async def run(repeat: int, boxes: int, only: list[str] | None, show: list[str] = ()) -> dict:
    figs = build_figures()
    layers, skipped, textual_plot = {}, {}, None
    for name, (available, draw) in LAYERS.items():
        if only and name not in only:
            continue
        reason = available()
        if reason:
            skipped[name] = reason
            print(f"{name}: {reason}")
            continue
        if name == "textual-plot":
            textual_plot = TextualPlotLayer()
            await textual_plot.start()
            draw = textual_plot.render
        layers[name] = draw
    results: dict = {}
    try:
        cases = [(f, c) for f in FIGURES for c in CANVASES]
        for name, draw in layers.items():
            for f in show:
                print(f"--- {name}: {f} 80x24")
                print("\n".join(text or "(cannot draw)" for text in frame(draw, figs[f], 80, 24)))
        for draw in layers.values():  # a warm-up frame each
            for f, (w, h) in cases:
                try:
                    frame(draw, figs[f], w, h)
                except Exception:  # noqa: BLE001 - the zoom check counts it
                    pass
        times: dict = {(n, f, c): [] for n in layers for f, c in cases}
        failures: dict = {}
        for _ in range(repeat):  # interleaved: every layer, figure and canvas in turn, per repeat
            for f, c in cases:
                for name, draw in layers.items():
                    start = time.perf_counter()
                    try:
                        frame(draw, figs[f], *c)
                    except Exception as exc:  # noqa: BLE001
                        failures[name, f, c] = type(exc).__name__
                        continue
                    times[name, f, c].append(time.perf_counter() - start)
            await asyncio.sleep(0)
        for name, draw in layers.items():
            for f, c in cases:
                row = times[name, f, c]
                results.setdefault(name, {})[f"{f} {c[0]}x{c[1]}"] = {
                    "median_ms": 1000 * statistics.median(row) if row else None,
                    "frames": len(row),
                    "unzoomed_failure": failures.get((name, f, c)),
                    "zoom": zoom_check(draw, figs[f], *c, boxes, f"{f}{c}"),
                }
            print(f"{name}: done", file=sys.stderr)
    finally:
        if textual_plot is not None:
            await textual_plot.stop()
    return {
        "python": sys.version.split()[0],
        "venv": sys.prefix,
        "repeat": repeat,
        "boxes": boxes,
        "date": time.strftime("%Y-%m-%d"),
        "layers": results,
        "skipped": skipped,
        "packages": {name: package_facts(PACKAGES[name]) for name in LAYERS},
    }


def table(report: dict) -> str:
    lines = [
        f"{'layer':<13} {'figure':<16} {'ms/frame':>9} {'exceptions':>10} {'cannot':>7} {'blank':>6}  of (a curve's sample inside)"
    ]
    for name, rows in report["layers"].items():
        for case, r in rows.items():
            z = r["zoom"]
            ms = f"{r['median_ms']:.1f}" if r["median_ms"] is not None else "-"
            types = ",".join(f"{k}:{v}" for k, v in z["exception_types"].items())
            lines.append(
                f"{name:<13} {case:<16} {ms:>9} {z['exceptions']:>10} {z['cannot_draw']:>7} {z['blank']:>6}"
                f"  {z['panels_drawn']} ({z['with_a_sample_inside']}) {types}"
            )
    for name, reason in report["skipped"].items():
        lines.append(f"{name:<13} {reason}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15, help="interleaved timed frames per layer, figure and canvas")
    parser.add_argument("--boxes", type=int, default=300, help="random zoom/pan boxes per figure and canvas")
    parser.add_argument("--layers", nargs="*", choices=list(LAYERS), help="only these layers")
    parser.add_argument("--show", nargs="*", choices=FIGURES, help="print each layer's frame of these figures (80x24)")
    parser.add_argument("--out", default="plot-layers.json", help="the JSON report (not committed)")
    args = parser.parse_args(argv)
    report = asyncio.run(run(args.repeat, args.boxes, args.layers, args.show or []))
    print(table(report))
    Path(args.out).write_text(json.dumps(report, indent=1))
    print(f"written {args.out}")


if __name__ == "__main__":
    main()

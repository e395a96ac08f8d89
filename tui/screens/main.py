"""The workbench screen: Run (plots and tableau), Plant, Targets and History
tabs over one `Workbench`.  Widgets only read the workbench; edits go
through `tui.editing`, stepping through the app's worker."""

from __future__ import annotations

import math

from textual.app import ComposeResult
from textual.binding import Binding
from rich.text import Text
from textual.containers import Horizontal, Vertical, VerticalScroll
from textual.screen import Screen
from textual.widgets import DataTable, Footer, TabbedContent, TabPane

from engine.algorithm import MeasureRow, StepRecord

from ..widgets.plots import (FigurePlot, bode_figures, line_figure, nichols_figure, nyquist_figure, step_figure,
                             sweep_figure,
                             trajectories_figure)
from ..editing import bands_text, objective_rows
from ..widgets.textview import TextView
from ..workbench import Workbench


SHORT = {"gain_margin": "G", "phase_margin": "P", "stability_margin": "S", "attenuation_margin": "A",
         "gain_margin_db": "GM dB", "phase_margin_deg": "PM deg", "crossover_frequency": "wc",
         "averaged_square": "avg sq", "modal_peak_db": "peak", "modal_peak_phase_deg": "pk ph",
         "stability_abscissa": "stab", "peak_response": "resp pk", "mean_square": "msq", "rise_time": "rise",
         "settling_time": "settle", "overshoot_percent": "OS %", "peak_time": "t peak", "steady_state_error": "ss err"}


def _fmt(value, digits: int = 6) -> str:
    if value is None:
        return ""
    if isinstance(value, float) and math.isnan(value):
        return "-"  # no such crossing in the band (as `loopcraft report` prints it)
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


class MainScreen(Screen):
    """Tabs: 1 run, 2 plant, 3 targets, 4 history."""

    BINDINGS = [Binding("p", "next_plot", "next plot"), Binding("1", "tab('run')", "run", show=False), Binding("2", "tab('plant')", "plant", show=False),
                Binding("3", "tab('targets')", "targets", show=False),
                Binding("4", "tab('history')", "history", show=False),
                Binding("5", "tab('sweep')", "sweep", show=False)]
    DEFAULT_CSS = """
    MainScreen { overflow: hidden; }
    #status { height: 1; background: $boost; padding: 0 1; }
    #tabs { height: 1fr; }
    #tabs > ContentSwitcher { height: 1fr; }
    #plots > ContentSwitcher { height: 1fr; }
    #plots { width: 3fr; }
    #tableau-side { width: 2fr; }
    #tableau-scroll { height: 1fr; }
    #tableau { height: auto; }
    #step-info { height: 6; }
    #bode-mag, #bode-phase { height: 1fr; }
    #blocks, #parameters, #targets-table, #objective-table, #history-table, #history-side { height: 1fr; }
    #history-plot, #history-scroll { height: 1fr; }
    """

    def __init__(self, bench: Workbench):
        super().__init__()
        self.bench = bench

    def compose(self) -> ComposeResult:
        yield TextView("", id="status")
        with TabbedContent(id="tabs", initial="run"):
            with TabPane("Run", id="run"):
                with Horizontal():
                    with TabbedContent(id="plots"):
                        with TabPane("Nyquist", id="p-nyquist"):
                            yield FigurePlot(id="nyquist")
                        with TabPane("Bode", id="p-bode"):
                            with Vertical():
                                yield FigurePlot(id="bode-mag")
                                yield FigurePlot(id="bode-phase")
                        with TabPane("Nichols", id="p-nichols"):
                            yield FigurePlot(id="nichols")
                        with TabPane("Convergence", id="p-convergence"):
                            yield FigurePlot(id="convergence")
                        with TabPane("Step", id="p-step"):
                            yield FigurePlot(id="step")
                        with TabPane("Trajectories", id="p-trajectories"):
                            yield FigurePlot(id="trajectories")
                    with Vertical(id="tableau-side"):
                        with VerticalScroll(id="tableau-scroll"):
                            yield TextView("", id="tableau")
                        yield TextView("", id="step-info")
            with TabPane("Plant", id="plant"):
                with Vertical():
                    yield DataTable(id="blocks", cursor_type="row")
                    yield DataTable(id="parameters", cursor_type="row")
            with TabPane("Targets", id="targets"):
                with Vertical():
                    yield DataTable(id="targets-table", cursor_type="row")
                    yield DataTable(id="objective-table", cursor_type="row")
            with TabPane("History", id="history"):
                with Horizontal():
                    yield DataTable(id="history-table", cursor_type="row")
                    with Vertical(id="history-side"):
                        yield FigurePlot(id="history-plot")
                        with VerticalScroll(id="history-scroll"):
                            yield TextView("", id="history-tableau")
            with TabPane("Sweep", id="sweep"):
                with Horizontal():
                    yield FigurePlot(id="sweep-plot")
                    with Vertical(id="sweep-side"):
                        yield TextView("", id="sweep-status")
                        yield DataTable(id="optima-table", cursor_type="row")
        yield Footer()

    def on_mount(self) -> None:
        if not self.bench.session.problem.conditions:     # no loop to draw: show the trajectories
            self.query_one("#plots", TabbedContent).active = "p-trajectories"
        self.refresh_all()

    PLOT_TABS = ("p-nyquist", "p-bode", "p-nichols", "p-convergence", "p-step", "p-trajectories")

    def action_next_plot(self) -> None:
        plots = self.query_one("#plots", TabbedContent)
        plots.active = self.PLOT_TABS[(self.PLOT_TABS.index(plots.active) + 1) % len(self.PLOT_TABS)]
        self.refresh_plots()

    def action_tab(self, name: str) -> None:
        self.query_one("#tabs", TabbedContent).active = name

    def on_tabbed_content_tab_activated(self, event: TabbedContent.TabActivated) -> None:
        if event.tabbed_content.id == "tabs" and getattr(self, "_history_stale", True):
            self.refresh_history()

    # -- refreshing ---------------------------------------------------------

    def refresh_all(self) -> None:
        self.refresh_status()
        self.refresh_run()
        self.refresh_plant()
        self.refresh_targets()
        self.refresh_history()
        self.refresh_sweep()

    def refresh_status(self) -> None:
        b = self.bench
        name = b.session.path.name if b.session.path else "untitled"
        mark = " *" if b.dirty else ""
        self.query_one("#status", TextView).set(
            f"[b]{name}{mark}[/b]  algorithm [b]{b.algorithm_name}[/b]  Iteration {b.iteration}  {b.status_text()}")

    def refresh_run(self, plots: bool = True, figures: dict | None = None, prebuilt: dict | None = None) -> None:
        rows, record = self.bench.tableau()
        previous = self.bench.tableau(self.bench.iteration - 1)[0] if self.bench.iteration > 0 else []
        self.query_one("#tableau", TextView).set(self._tableau_text(rows, previous))
        self.query_one("#step-info", TextView).set(self._step_info(record))
        if plots:
            self.refresh_plots(figures, prebuilt)

    PLOTS = ("nyquist", "bode-mag", "bode-phase", "nichols", "convergence", "step", "trajectories", "sweep-plot")

    def figures(self) -> dict[str, object]:
        """Every plot's figure from the workbench (safe to call from the worker thread)."""
        b = self.bench
        curves = b.loop_curves()
        figures: dict[str, object] = {}
        if curves:
            figures["nyquist"] = nyquist_figure(curves, self._points(), self._radius())
            figures["bode-mag"], figures["bode-phase"] = bode_figures(curves, b.session.problem.grid.unit)
            figures["nichols"] = nichols_figure(curves)
        label, its, values = b.convergence()
        figures["convergence"] = line_figure("Convergence", "iteration", label or "value", its, values,
                                             "no iterations yet")
        records = b.records
        if not records and not b.session.problem.conditions:  # no loop, trajectories only: iteration 0's record
            records = [r for r in [b.initial_record()] if r]
        objective = b.session.problem.objective
        figures["trajectories"] = trajectories_figure(b.trajectories(), records, objective.data if objective else None)
        figures["step"] = step_figure(*b.step_traces())
        figures["sweep-plot"] = sweep_figure(b.latest_sweep())
        return figures

    def canvases(self) -> dict[str, tuple[int, int, str]]:
        """The size and theme of every plot that is on screen now."""
        out = {}
        for name in self.PLOTS:
            plot = self.query_one(f"#{name}", FigurePlot)
            if plot.display and plot.size.width > 0 and plot.region.width > 0:
                out[name] = plot.canvas()
        return out

    def refresh_plots(self, figures: dict | None = None, prebuilt: dict | None = None) -> None:
        figures = self.figures() if figures is None else figures
        for name, figure in figures.items():
            self.query_one(f"#{name}", FigurePlot).show(figure, (prebuilt or {}).get(name))

    def _points(self) -> list[tuple[complex, str]]:
        return [(p.value, p.mode) for t in self.bench.session.problem.targets for p in t.points]

    def _radius(self) -> float | None:
        for t in self.bench.session.problem.targets:
            if t.measure == "stability_margin" and t.bands:
                return t.bands[0].desired
        return None

    def _tableau_text(self, rows: list[MeasureRow], previous: list[MeasureRow]) -> Text:
        """The tableau as one text (far cheaper to draw than a table widget while a run goes):
        values changed since ``previous`` in bold, unmet rows marked NO in red."""
        unit = self.bench.session.problem.grid.unit
        scale = 1 / (2 * 3.141592653589793) if unit == "hz" else 1.0
        before = {(r.name, r.kind, r.condition): r.value for r in previous}
        several = len({r.condition for r in rows}) > 1
        text = Text(f"{'no.':<8} " + (f"{'condition':<10} " if several else "")
                    + f"{'kind':<6} {'value':>9} met {'target':>7} {'freq ' + unit:>10}\n", style="bold",
                    no_wrap=True, overflow="crop")
        for r in rows:
            key = (r.name, r.kind, r.condition)
            changed = key in before and before[key] != r.value
            freq = "" if r.frequency is None else _fmt(r.frequency * scale, 5)
            text.append(f"{r.name[:8]:<8} " + (f"{r.condition[:10]:<10} " if several else "")
                        + f"{SHORT.get(r.kind, r.kind)[:6]:<6} ")
            text.append(f"{_fmt(r.value, 5):>9}", style="bold" if changed else "")
            text.append(" yes " if r.satisfied else " NO  ", style="" if r.satisfied else "bold red")
            text.append(f"{_fmt(r.target, 4):>7} {freq:>10}\n")
        methods = sorted({r.method for r in rows if r.method})
        if methods:
            text.append(f"margins: {', '.join(methods)}\n", style="dim")
        return text

    def _step_info(self, record: StepRecord | None) -> str:
        if record is None:
            return "no iterations yet: [b]s[/b] steps, [b]r[/b] runs, [b]?[/b] help"
        parts = [f"step {_fmt(record.step_size, 4)}"] if record.step_size is not None else []
        if record.objective is not None:
            parts.append(f"objective {_fmt(record.objective, 7)}")
        parts += [f"{k} {v}" for k, v in record.counters.items() if k in ("trials", "KNT", "KOUNT", "evaluations")]
        lines = ["  ".join(parts)]
        e = record.extra
        if "major" in e:  # slp: the minor loop's trial
            lines.append(f"major {e['major']} minor {e['minor']}  P {_fmt(e['P'], 3)}  STEP {e['STEP']:.1f}  "
                         f"{'accepted' if e['accepted'] else 'rejected'}  counter {e['counter']}")
        for comp in record.extra.get("compensators", [])[:2]:
            lines.append(f"{comp['group']}: num {' '.join(f'{c:.4g}' for c in comp['numerator'])}")
            lines.append(f"{'':{len(comp['group'])}}  den {' '.join(f'{c:.4g}' for c in comp['denominator'])}")
        params = record.parameters
        if not record.extra.get("compensators"):
            lines.append("  ".join(f"{k}={_fmt(v, 5) if not isinstance(v, list) else '/'.join(_fmt(u, 3) for u in v)}"
                                   for k, v in list(params.items())[:8]))
        return "\n".join(lines)

    def refresh_plant(self) -> None:
        model = self.bench.session.model.problem
        blocks = self.query_one("#blocks", DataTable)
        blocks.clear(columns=True)
        blocks.add_columns("condition", "block", "input", "output", "kind", "definition")
        for condition in model.conditions:
            for name, inp, out, kind, text in plant_rows(condition):
                blocks.add_row(condition.name, name, inp, out, kind, text)
        params = self.query_one("#parameters", DataTable)
        params.clear(columns=True)
        params.add_columns("parameter", "value", "min", "max", "free", "per condition")
        free = {p.name: p.free for p in self.bench.session.problem.parameters}
        for p in model.parameters:
            state = "free" if free.get(p.name, p.free) else ("held" if p.free else "fixed")
            params.add_row(p.name, _fmt(p.value if not isinstance(p.value, list) else p.value[0]),
                           _fmt(p.min), _fmt(p.max), state, "yes" if isinstance(p.value, list) else "shared")

    def refresh_targets(self) -> None:
        model = self.bench.session.model.problem
        table = self.query_one("#targets-table", DataTable)
        table.clear(columns=True)
        table.add_columns("measure", "condition", "bands (low..high: desired / required)", "points", "weight",
                          "detect", "unit")
        for t in model.targets:
            bands = bands_text(t)
            points = " ".join(f"{q.mode} {complex(q.real, q.imag)}" for q in t.points) or "default"
            detect = f"{t.detect_low:g}..{'inf' if t.detect_high is None else f'{t.detect_high:g}'}"
            table.add_row(t.measure, t.condition or "all", bands, points, _fmt(t.weight), detect, t.unit)
        objective = self.query_one("#objective-table", DataTable)
        objective.clear(columns=True)
        objective.add_columns("objective / setting", "value")
        for label, value, _ in objective_rows(self.bench):
            objective.add_row(label, value)

    def refresh_history(self) -> None:
        """The history table, rebuilt only while its tab is shown (else on the next visit)."""
        if self.query_one("#tabs", TabbedContent).active != "history":
            self._history_stale = True
            return
        self._history_stale = False
        table = self.query_one("#history-table", DataTable)
        table.clear(columns=True)
        table.add_columns("iteration", "status", "value", "unmet")
        label, its, values = self.bench.convergence()
        value_at = dict(zip(its, values))
        table.add_row("0", "start", "", "")
        for r in self.bench.records:
            unmet = sum(not m.satisfied for m in r.measures)
            table.add_row(str(r.iteration), r.status.value, _fmt(value_at.get(r.iteration), 6), str(unmet))

    def refresh_sweep(self, progress: str | None = None) -> None:
        """The latest sweep: status line, its optima (or worst case) and its plot."""
        sweep = self.bench.latest_sweep()
        if progress is not None:
            self.query_one("#sweep-status", TextView).set(progress)
            return
        status = "no sweep yet.  [b]w[/b] starts one (starts 16 | vary NAME=V1,V2 | tolerance NAME=+-10%)"
        table = self.query_one("#optima-table", DataTable)
        table.clear(columns=True)
        if sweep:
            status = (f"{sweep['kind']} sweep of {sweep['created']}: {len(sweep['runs'])} runs on {sweep['workers']} "
                      f"worker(s), {len(sweep['failed'])} failed, {len(sweep['retried'])} retried"
                      + (", cancelled" if sweep["cancelled"] else "") + ".  [b]u[/b] uses the best optimum")
            if sweep["kind"] == "tolerance":
                table.add_columns("measure", "condition", "worst", "target", "unmet/samples")
                for w in sweep["worst_case"]:
                    table.add_row(w["name"], w["condition"], _fmt(w["worst"], 5), _fmt(w["target"], 4),
                                  f"{w['unmet_samples']}/{w['samples']}")
            else:
                table.add_columns("optimum", "count", "meets", "objective", "best run", "parameters")
                for k, o in enumerate(sweep["optima"], start=1):
                    params = "  ".join(f"{n}={_fmt(v if not isinstance(v, list) else v[0], 4)}"
                                       for n, v in o["parameters"].items())
                    table.add_row(str(k), str(o["count"]), "yes" if o["meets_requirements"] else "no",
                                  _fmt(o["objective"], 6), str(o["best_run"]), params)
        self.query_one("#sweep-status", TextView).set(status)
        self.query_one("#sweep-plot", FigurePlot).show(sweep_figure(sweep))

    def show_history_iteration(self, iteration: int) -> None:
        """The selected iteration's loop (beside the current design) and its tableau."""
        rows, _ = self.bench.tableau(iteration)
        self.query_one("#history-tableau", TextView).set(self._tableau_text(rows, []))
        figure = nyquist_figure(self.bench.loop_curves(iteration), self._points(), self._radius(),
                                f"Nyquist: iteration {iteration}" if iteration else "Nyquist: start")
        self.query_one("#history-plot", FigurePlot).show(figure)

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        if event.data_table.id in ("blocks", "parameters", "targets-table", "objective-table"):
            self.app.action_edit()

    def on_data_table_row_highlighted(self, event: DataTable.RowHighlighted) -> None:
        if event.data_table.id == "history-table" and event.cursor_row is not None:
            self.show_history_iteration(event.cursor_row)


def plant_rows(condition) -> list[tuple[str, str, str, str, str]]:
    """(block, input, output, kind, definition) rows of a condition's plant model."""
    plant = condition.plant
    if plant.format == "diagram":
        rows = [(b.name, b.input, b.output, b.transfer.kind, describe(b.transfer)) for b in plant.blocks]
        rows += [(j.name, " ".join([f"+{s}" for s in j.plus] + [f"-{s}" for s in j.minus]), j.output, "junction", "")
                 for j in plant.junctions]
        rows.append(("(loop broken at)", condition.break_at, "", "", ""))
        return rows
    if plant.format == "channels":
        rows = []
        for ch in plant.channels:
            rows.append((f"{ch.name}.response", "e", f"{ch.name}.theta", ch.response.kind, describe(ch.response)))
            for k, sub in enumerate(ch.compensators, start=1):
                rows.append((f"{ch.name}.{k}", "", "", "polynomial",
                             f"({', '.join(map(str, sub.numerator))}) / ({', '.join(map(str, sub.denominator))})"))
        return rows
    if plant.format == "cascade":
        return [(name.upper(), "", "", t.kind, describe(t)) for name in ("g1", "g2", "g1g2", "ga", "h1", "h2")
                if (t := getattr(plant, name)) is not None]
    return [(f"a[{e.row},{e.col}]", "", "", "matrix entry", e.expression) for e in plant.entries]


def describe(transfer) -> str:
    """A one-line definition of a transfer model."""
    kind = transfer.kind
    if kind == "expression":
        return transfer.expression
    if kind == "table":
        t = transfer.table
        return f"table {t.csv or 'inline'} ({t.form}, {t.unit}, gain {t.gain:g})"
    if kind == "controller":
        factors = " ".join(f"{f.kind}({f.b if 'complex' not in f.kind else f'{f.damping},{f.frequency}'})"
                           for f in transfer.factors)
        return f"{transfer.gain} s^{transfer.s_power} {factors}"
    if kind == "polynomial":
        return f"({', '.join(map(str, transfer.numerator))}) / ({', '.join(map(str, transfer.denominator))})"
    if kind == "delay":
        return f"exp(-s*{transfer.tau})"
    return kind

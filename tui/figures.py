"""Every plot's figure from a `View`: pure data, safe off the UI thread (a
run's worker builds them from its own view; the screen shows them)."""

from __future__ import annotations

from .analysis_views import poles_figure, sensitivity_figure
from .views import View
from .widgets.loop_figures import bode_figures, nichols_figure, nyquist_figure
from .widgets.plots import Figure, line_figure, step_figure, sweep_figure, trajectories_figure


def points(view: View) -> list[tuple[complex, str]]:
    """The targets' push/pull points (drawn on the Nyquist plot)."""
    return [(p.value, p.mode) for t in view.problem.targets for p in t.points]


def disk(view: View) -> float | None:
    """The first disk-margin target's desired alpha (its exclusion disk on the Nyquist plot)."""
    for t in view.problem.targets:
        if t.measure == "disk_margin" and t.bands:
            return t.bands[0].desired
    return None


def radius(view: View) -> float | None:
    """The first stability-margin target's desired radius (a circle about -1)."""
    for t in view.problem.targets:
        if t.measure == "stability_margin" and t.bands:
            return t.bands[0].desired
    return None


def figures(view: View) -> dict[str, Figure]:
    """The figures of the plots the algorithm's presenter says apply, by plot id."""
    wanted = view.presenter.plots
    out: dict[str, Figure] = {}
    curves = view.loop_curves() if wanted & {"nyquist", "bode", "nichols"} else []
    if curves:
        out["nyquist"] = nyquist_figure(curves, points(view), radius(view), disk=disk(view), unit=view.problem.grid.unit)
        out["bode-mag"], out["bode-phase"] = bode_figures(curves, view.problem.grid.unit)
        out["nichols"] = nichols_figure(curves, view.problem.grid.unit)
    if "closed_loop" in wanted and view.problem.conditions:
        out["closed-loop"] = sensitivity_figure(view)
    if "poles" in wanted and view.problem.conditions:
        out["poles"] = poles_figure(view)
    label, its, values = view.convergence()
    out["convergence"] = line_figure("Convergence", "iteration", label or "value", its, values, "no iterations yet")
    if "trajectories" in wanted:
        objective = view.problem.objective
        out["trajectories"] = trajectories_figure(view.trajectories(), objective.data if objective else None)
    if "step" in wanted:
        out["step"] = step_figure(*view.step_plot())
    out["sweep-plot"] = sweep_figure(view.sweep)
    return out


OVERLAYS = ("nyquist", "bode", "step")


def history_figure(view: View, iteration: int, marked: int | None = None, kind: str = "nyquist") -> Figure:
    """An earlier iteration beside the current design, or beside the ``marked`` one:
    their Nyquist, Bode magnitude or step curves overlaid."""
    name = lambda k: f"iteration {k}" if k else "start"   # noqa: E731
    if marked is None or marked == iteration:
        curves, title = view.loop_curves(iteration), name(iteration)
    else:
        k = view.plotted()[0] if view.plotted() else 0
        curves = [c for c in (view.loop_curve(iteration, name(iteration), k, "blue"),
                              view.loop_curve(marked, f"{name(marked)} (marked)", k, "gray")) if c is not None]
        title = f"{name(iteration)} against {name(marked)}"
    if kind == "bode":
        magnitude, _ = bode_figures(curves, view.problem.grid.unit)
        magnitude.title = f"Bode magnitude: {title}"
        return magnitude
    if kind == "step" and marked is not None and marked != iteration:
        k = view.plotted()[0] if view.plotted() else 0
        traces = [(r.t, r.y, label, color) for at, label, color in ((iteration, name(iteration), "blue"),
                                                                   (marked, f"{name(marked)} (marked)", "gray"))
                  if (r := view.step(at, k)) is not None]
        fig = step_figure(traces[0][2] if traces else "", traces)
        fig.title = f"Step: {title}"
        return fig
    if kind == "step":
        return step_figure(*view.step_traces())
    return nyquist_figure(curves, points(view), radius(view), f"Nyquist: {title}")

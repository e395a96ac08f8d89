"""Every plot's figure from a `View`: pure data, safe off the UI thread (a
run's worker builds them from its own view; the screen shows them)."""

from __future__ import annotations

from collections.abc import Collection

from tui.figures import overlays
from tui.figures.closed_loop import poles_figure, sensitivity_figure
from tui.figures.data import Figure
from tui.figures.lines import line_figure, step_figure
from tui.figures.open_loop import bode_figures, nichols_figure, nyquist_figure
from tui.figures.requirements import Requirement, requirements
from tui.figures.trajectories import trajectories_figure
from tui.state.views import View


def points(view: View) -> list[tuple[complex, str]]:
    """The targets' push/pull points (drawn on the Nyquist plot)."""
    return [(p.value, p.mode) for t in view.problem.targets for p in t.points]


def applicable(plots: frozenset[str], problem) -> frozenset[str]:
    """The presenter's ``plots`` that the problem can draw: no loop plots without a
    loop, no poles or locus without a rational one."""
    conditions = problem.conditions
    if not conditions:
        return plots - {"nyquist", "bode", "nichols", "step", "closed_loop", "poles", "locus"}
    if not any(c.network.rational for c in conditions):
        return plots - {"poles", "locus"}  # a tabulated loop has no poles to show
    return plots


# the plot ids `figures` draws (the root locus and History's plot are drawn by their own workers, the
# Sweep tab's by the screen from the sweep's data: its histogram follows the row highlighted)
FIGURE_IDS = frozenset(
    {
        "nyquist",
        "bode-mag",
        "bode-phase",
        "nichols",
        "closed-loop",
        "poles",
        "convergence",
        "trajectories",
        "step",
    }
)


COARSE_POINTS = 200  # the frequencies of a drag's frame (about two a column of a 120-column plot)


def figures(view: View, only: Collection[str] | None = None, coarse: bool = False) -> dict[str, Figure]:
    """The figures of the plots the algorithm's presenter says apply, by plot id
    (``only``: just these plot ids, those shown: each plot costs its own search).
    ``coarse``: a drag's frame, the loop on `COARSE_POINTS` of the grid's frequencies
    and its margins unmarked (a tabulated loop's are a rational fit's, seconds on a
    large table), the titles saying so; the release draws them exact."""
    wanted = view.presenter.plots

    def asked(*names: str) -> bool:
        return only is None or any(name in only for name in names)

    out: dict[str, Figure] = {}
    curves = (
        view.loop_curves(
            with_margins=asked("bode-mag", "bode-phase") and not coarse, points=COARSE_POINTS if coarse else None
        )
        if wanted & {"nyquist", "bode", "nichols"} and asked("nyquist", "bode-mag", "bode-phase", "nichols")
        else []
    )
    unit = view.problem.grid.unit
    at = view.break_title()  # the break the loop plots are drawn at, in their titles
    roots = compensator_roots(view) if asked("bode-mag", "bode-phase", "poles") else []  # for both, read once
    if curves and asked("nyquist"):
        out["nyquist"] = nyquist_figure(curves, points(view), f"Nyquist (GH plane){at}", unit)  # `overlays.nyquist`
    if curves and asked("bode-mag", "bode-phase"):
        out["bode-mag"], out["bode-phase"] = bode_figures(curves, unit, at)
        sample_time = view.problem.conditions[view.first_plotted].network.sample_time
        overlays.corners(out["bode-mag"], roots, unit, sample_time)
        if not view.at_chosen_break():  # the compensator's gain moves another break's loop otherwise
            overlays.gain_drag(out["bode-mag"])
        overlays.nyquist_frequency(out["bode-mag"], out["bode-phase"], sample_time, unit)
    if curves and asked("nichols"):
        out["nichols"] = nichols_figure(curves, unit, f"Nichols{at}")
    if "closed_loop" in wanted and view.problem.conditions and asked("closed-loop"):
        out["closed-loop"] = sensitivity_figure(view)
    if "poles" in wanted and view.problem.conditions and asked("poles"):
        out["poles"] = poles_figure(view)
        overlays.compensator_roots(out["poles"], roots)
    if asked("convergence"):
        label, its, values = view.convergence()
        out["convergence"] = line_figure("Convergence", "iteration", label or "value", its, values, "no iterations yet")
    if "trajectories" in wanted and asked("trajectories"):
        objective = view.problem.objective
        out["trajectories"] = trajectories_figure(view.trajectories(), objective.data if objective else None)
    if "step" in wanted and asked("step"):
        name, traces, marks = view.step_plot()
        out["step"] = step_figure(name, traces, marks)
        overlays.step(out["step"], requirements(view), marks.final if marks is not None else None)
    _overlay(out, requirements(view), unit)
    if coarse:
        for figure in out.values():
            figure.title = f"{figure.title} (coarse: exact on release)"
    return out


def compensator_roots(view: View) -> list[overlays.CompensatorRoot]:
    """The zeros and poles (the upper root of a pair) of the plotted condition's
    compensators at the current design, each with its item's name as the shaping table
    gives it (`engine.design.compensator_items`; none when they do not read); a sampled
    loop's in z, as its pole map and locus are drawn."""
    from engine.design.compensator_items import named, readings
    from engine.errors import EngineError
    from engine.model.bilinear import z_of_w
    from engine.model.blocks import ExpressionTransfer

    if not view.problem.conditions:
        return []
    k = view.first_plotted
    values = view.parameters(None, k)
    out = []
    for entry in view.problem.conditions[k].network.entries:
        if isinstance(entry.transfer, ExpressionTransfer) and entry.transfer.parameters:
            try:
                found = readings(entry.transfer, values)  # (the parameters that move them are not drawn)
            except (EngineError, ValueError):
                continue
            kinds = {"zero": "zero", "zero pair": "zero", "differentiator": "zero"}
            out += [
                overlays.CompensatorRoot(kinds.get(i.kind, "pole"), i.root, f"{entry.label}.{name}")
                for i, name in zip(found, named(found))
                if i.kind != "gain"
            ]
    if view.problem.conditions[k].network.sample_time is not None:
        out = [overlays.CompensatorRoot(r.kind, complex(z_of_w(r.root)), r.name) for r in out]
    return out


def _overlay(out: dict[str, Figure], found: list[Requirement], unit: str) -> None:
    """The targets' requirements drawn on the loop plots and the pole map (the step plot's
    are drawn with its marks)."""
    if not found:
        return
    if "bode-mag" in out:
        overlays.bode(out["bode-mag"], out["bode-phase"], found, unit)
    if "nichols" in out:
        overlays.nichols(out["nichols"], found)
    if "nyquist" in out:
        overlays.nyquist(out["nyquist"], found)
    if "poles" in out:
        overlays.poles(out["poles"], found)


class Same:
    """An object in a key, equal only to itself and held there: an `id` alone could be
    taken again by a new object once the old one is freed (an edited problem, an undone
    iteration's record), and a plot of the old design would pass for current."""

    __slots__ = ("held",)

    def __init__(self, held: object) -> None:
        self.held = held

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Same) and other.held is self.held

    def __hash__(self) -> int:
        return id(self.held)


def figure_key(view: View) -> tuple:
    """What a view's figures depend on: the problem, the records (the last one's
    identity: an undo then a new step has the same count), the condition and the
    break shown and the step plot's setup."""
    last = view.records[-1] if view.records else None
    return (Same(view.problem), view.iteration, Same(last), view.plotted_condition, view.step_setup, view.plotted_break)

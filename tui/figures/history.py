"""The History tab's figures: one view (Nyquist, Bode magnitude or phase,
Nichols, S/T, poles, locus, step) of an iteration's design beside a
reference, the marked iteration or else the current design (`View.shown`:
with several plotted conditions, each condition at that iteration).  Pure
data from a `View`, safe off the UI thread (the History pane computes them
in a worker)."""

from __future__ import annotations

from dataclasses import replace

from engine.analysis import LoopCurve
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.margins.search import margins
from tui.figures import overlays
from tui.figures.catalog import applicable, points
from tui.figures.closed_loop import Design, locus_figure, poles_figure, sensitivity_figure
from tui.figures.data import Figure
from tui.figures.lines import step_figure
from tui.figures.open_loop import bode_figures, nichols_figure, nyquist_figure
from tui.figures.requirements import requirements
from tui.state.views import View

# the views, in the order o (or p) cycles them: title, and the presenter's plot each needs
VIEWS = {
    "nyquist": ("Nyquist", "nyquist"),
    "bode": ("Bode", "bode"),
    "phase": ("phase", "bode"),
    "nichols": ("Nichols", "nichols"),
    "closed-loop": ("S/T", "closed_loop"),
    "poles": ("poles", "poles"),
    "locus": ("locus", "locus"),
    "step": ("step", "step"),
}
TITLES = {
    "nyquist": "Nyquist",
    "bode": "Bode magnitude",
    "phase": "Bode phase",
    "nichols": "Nichols",
    "closed-loop": "S/T",
    "poles": "Poles and zeros",
    "locus": "Root locus",
    "step": "Step",
}


def history_views(plots: frozenset[str], problem) -> list[str]:
    """The views that apply to a session's designs: the presenter's ``plots`` the problem
    can draw (`figures.applicable`); the step response only of a rational loop."""
    wanted = applicable(plots, problem)
    rational = any(c.network.rational for c in problem.conditions)
    return [name for name, (_, plot) in VIEWS.items() if plot in wanted and (name != "step" or rational)]


def name(iteration: int) -> str:
    return f"iteration {iteration}" if iteration else "start"


def designs(view: View, iteration: int, marked: int | None = None) -> list[Design]:
    """What a view draws: the iteration and the marked one (the first plotted condition),
    else `View.shown` (the iteration beside the current design, or each condition)."""
    if marked is None or marked == iteration:
        return view.shown(iteration)
    k = view.first_plotted
    return [(iteration, k, name(iteration), "current"), (marked, k, f"{name(marked)} (marked)", "reference")]


def subject(view: View, iteration: int, marked: int | None, condition: int | None = None) -> str:
    """'iteration 3', 'iteration 3 vs marked start', and the condition when one of several is drawn."""
    text = (
        name(iteration)
        if marked is None or marked == iteration
        else f"{name(iteration)} vs marked {marked if marked else 'start'}"
    )
    conditions = view.problem.conditions
    return f"{text} ({conditions[condition].name})" if len(conditions) > 1 and condition is not None else text


def history_figure(
    view: View, iteration: int, marked: int | None = None, kind: str = "nyquist", parameter: str = "gain"
) -> Figure:
    """One view of an iteration's design beside its reference (`designs`); the root
    locus (in ``parameter``) of the iteration alone."""
    if kind == "locus":
        k = view.first_plotted
        fig = locus_figure(view, parameter, iteration, subject(view, iteration, None, k))
        overlays.poles(fig, requirements(view, iteration))
        return fig
    drawn = designs(view, iteration, marked)
    if kind in ("nyquist", "bode", "phase", "nichols"):
        curves = [c for c in (view.loop_curve(at, label, k, role) for at, k, label, role in drawn) if c is not None]
        fig = _loop_figure(view, _margins_of_the_first(view, drawn, curves), kind, iteration)
    elif kind == "closed-loop":
        fig = sensitivity_figure(view, drawn)
    elif kind == "poles":
        fig = poles_figure(view, drawn)
        overlays.poles(fig, requirements(view, iteration))
    else:
        fig = _step_figure(view, drawn)
    one = drawn and (len({k for _, k, _, _ in drawn}) == 1 or kind == "poles")  # poles: the first's condition
    about = subject(view, iteration, marked, drawn[0][1] if one else None)
    title = TITLES[kind] + (view.break_title() if kind in ("nyquist", "bode", "phase", "nichols") else "")
    if any(s.x for s in fig.series):
        fig.title = f"{title}: {about}" + _measures(fig.title, kind)
    else:
        fig.title, fig.empty_message = "", f"{title}: {about}: {fig.empty_message or 'nothing to draw'}"
    return fig


def _loop_figure(view: View, curves, kind: str, iteration: int) -> Figure:
    """A loop view with the requirements judged at the iteration drawn on it."""
    unit = view.problem.grid.unit
    found = requirements(view, iteration)
    if kind in ("nyquist", "nichols"):
        fig = nyquist_figure(curves, points(view), unit=unit) if kind == "nyquist" else nichols_figure(curves, unit)
        overlays.history(fig, kind, found, unit)
        return fig
    magnitude, phase = bode_figures(curves, unit)
    shown, partner = (magnitude, phase) if kind == "bode" else (phase, magnitude)
    overlays.history(shown, kind, found, unit, partner)
    return shown


def _margins_of_the_first(view: View, drawn: list[Design], curves: list[LoopCurve]) -> list[LoopCurve]:
    """The curves, the margins (marked on the Bode plots) on the first design's alone."""
    out = [replace(c, margins=None) for c in curves]
    if not out or drawn[0][3] == "reference" or len({k for _, k, _, _ in drawn}) > 1:
        return out
    at, k = drawn[0][:2]
    c = view.problem.conditions[k]
    try:
        out[0] = replace(
            out[0],
            margins=margins(loop_model(c.network, view.break_of(k), view.problem.grid.omega, view.parameters(at, k))),
        )
    except EngineError:
        pass
    return out


def _step_figure(view: View, drawn: list[Design]) -> Figure:
    """The designs' step responses over the first one's horizon, its rise time, overshoot
    and settling marked; the title keeps the measures alone, the signal is the y label."""
    traces, signal, span, marks = [], "", None, None
    for n, (at, k, label, role) in enumerate(drawn):
        response = view.step(at, k, span)
        if response is None:
            continue
        if not traces:
            span, signal, marks = response.t[-1], response.name, response.measures if n == 0 else None
        traces.append((response.t, response.y, label, role))
    fig = step_figure(signal, traces, marks)
    fig.title = fig.title.replace(f"Step response: {signal}", "", 1)
    fig.ylabel = signal or fig.ylabel
    return fig


def _measures(title: str, kind: str) -> str:
    """What a figure's own title gives after its name: the peaks of S/T, the step's measures."""
    if kind == "closed-loop":
        title = title.removeprefix("Closed loop: |S|, |T|")
    return f"  {title.strip()}" if kind in ("closed-loop", "step") and title.strip() else ""


def figure_key(view: View, iteration: int, marked: int | None, kind: str, parameter: str) -> tuple:
    """What a history figure depends on besides the problem: the designs' parameter
    values, labels and loop breaks, the locus parameter, the step setup."""
    if kind == "locus":
        k = view.first_plotted
        return kind, iteration, _frozen(view.parameters(iteration, k)), k, parameter
    drawn = tuple(
        (label, role, k, view.break_of(k), _frozen(view.parameters(at, k)))
        for at, k, label, role in designs(view, iteration, marked)
    )
    return kind, iteration, marked, drawn, view.step_setup if kind == "step" else None


def _frozen(values: dict[str, float]) -> tuple:
    return tuple(sorted(values.items()))

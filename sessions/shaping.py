"""Hand edits of a session's design, as the command line makes them (`loopcraft set`,
`loopcraft tune`): the design on screen (the current iteration's, else the start)
becomes the start (the run that led there kept, and the change noted as a hand move:
`sessions.hand_history`), then named parameters are set or scaled, or the loop gain is
solved for a crossover frequency or a phase margin (`engine.design.gain_solves`).  A command's
assignments are one change: bounds and constraints are checked once, on the design it asks for
(`committed`); a refusal names the assignment and the bound or constraint, and changes nothing."""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from engine.design.constraints import check_change
from engine.design.gain_solves import GainSolution, gain_for
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.responses import loop_model
from sessions.errors import SessionError
from sessions.format.limits import MAX_NAME
from sessions.format.schema import ProblemModel
from sessions.hand_history import note_edit, value_text
from sessions.lifecycle import adopt_current, rebuild
from sessions.store import Session

ASSIGNMENT = re.compile(r"^\s*([^=*]+?)\s*(\*?=)\s*([-+]?[^\s]+?)\s*(dB)?\s*$")
LINEAR = 1e-9  # relative: doubling a gain parameter doubles GH within this


@dataclass(frozen=True)
class Assignment:
    """``name = value`` or ``name *= factor`` (a factor in dB: ``K*=+3dB``); a name is a
    parameter, or a compensator's item ``BLOCK.ITEM`` (its frequency, or its gain) or
    ``BLOCK.ITEM.zeta`` (a pair's damping), items named as `compensator_items.named`."""

    name: str
    scale: bool
    value: float

    @staticmethod
    def parse(text: str) -> Assignment:
        match = ASSIGNMENT.match(text)
        if not match:
            raise SessionError(f"{text!r}: write NAME=VALUE, NAME*=FACTOR or NAME*=+3dB")
        name, op, number, db = match.groups()
        if any(len(part) > MAX_NAME for part in name.split(".")):
            raise SessionError(f"{text!r}: no name is that long (at most {MAX_NAME} characters between dots)")
        try:
            value = float(number)
        except ValueError:
            raise SessionError(f"{text!r}: {number!r} is not a number") from None
        if db and op != "*=":
            raise SessionError(f"{text!r}: dB scales a value: write {name}*={number}dB")
        if not math.isfinite(value):
            raise SessionError(f"{text!r}: the value must be finite")
        try:
            factor = 10 ** (value / 20) if db else value
        except OverflowError:
            raise SessionError(f"{text!r}: {number} dB is out of range (a factor above 1e308)") from None
        return Assignment(name, op == "*=", factor)


def assign(session: Session, assignments: list[Assignment]) -> list[str]:
    """Make the design on screen the start, then set or scale the named parameters (every
    condition's value of a per-condition one), the assignments one change: bounds and
    constraints checked once, at its end (`committed`); what changed, one line each."""
    adopt_current(session)
    before = session.model.problem.model_copy(deep=True)
    lines: list[str] = []
    changed: dict[str, str] = {}
    with committed(session, before, changed):
        for item in assignments:
            if "." in item.name:
                line, names = _move(session, item)
            else:
                line = _set(session, item.name, lambda v, item=item: v * item.value if item.scale else item.value)
                names = [item.name]
            lines.append(line)
            changed.update(dict.fromkeys(names, written(item)))
            rebuild(session, start_checked=False)  # the next assignment reads the values this one set
    note_edit(session, before)
    return lines


def written(item: Assignment) -> str:
    """An assignment as a command line writes it (``T1=3``, ``K*=2``)."""
    return f"{item.name}{'*=' if item.scale else '='}{item.value:g}"


@contextmanager
def committed(session: Session, before: ProblemModel, changed: dict[str, str]) -> Iterator[None]:
    """A hand change as one transaction: the body changes the model (rebuilt without the start's
    check); at its end the whole change is checked once (`engine.design.constraints.check_change`:
    bounds and constraints, naming the assignment).  A refusal puts ``before`` back."""
    try:
        yield
        check_change(session.problem, changed)
    except (SessionError, EngineError) as exc:
        session.model.problem = before.model_copy(deep=True)
        rebuild(session)
        raise SessionError(str(exc)) from None


def _move(session: Session, assignment: Assignment) -> tuple[str, list[str]]:
    """Move a compensator's item (``BLOCK.ITEM[.zeta]``) of the first condition by solving
    for the parameters that own it (`compensator_moves.move_named`), within its bounds."""
    from engine.design.compensator_moves import move_named

    problem = session.problem
    if not problem.conditions:
        raise SessionError(f"{assignment.name}: the session has no loop")
    bounds = {p.name: (p.min, p.max) for p in session.model.problem.parameters}
    change = (lambda now: now * assignment.value) if assignment.scale else (lambda now: assignment.value)
    try:
        move = move_named(problem.conditions[0].network, problem.condition_values(0), assignment.name, change, bounds)
    except EngineError as exc:
        raise SessionError(str(exc)) from None
    lines = [_set(session, name, lambda v, value=value: value, 0) for name, value in move.values.items()]
    return f"{assignment.name}: {move.now:.6g} -> {move.target:.6g} ({'; '.join(lines)})", list(move.values)


@dataclass(frozen=True)
class GainChoice:
    """One gain that gives a phase margin: the solution, the gain parameter's value then,
    and what else changes: the tableau's rows met now and not then (``breaks``), and not
    met now but then (``meets``)."""

    solution: GainSolution
    parameter: str
    value: float
    breaks: tuple[str, ...]
    meets: tuple[str, ...]

    @property
    def text(self) -> str:
        """One line: the crossover, the gain, what else changes."""
        s = self.solution
        changes = [f"breaks {', '.join(self.breaks)}"] if self.breaks else []
        changes += [f"meets {', '.join(self.meets)}"] if self.meets else []
        return f"crossover {s.frequency:.6g} rad/s: {self.parameter} = {self.value:.6g} (x {s.factor:.6g}); " + (
            "; ".join(changes) or "no requirement changes"
        )


def phase_margin_choices(
    session: Session,
    condition: int,
    phase_margin: float,
    parameter: str | None = None,
    named: Mapping[str, float | Sequence[float]] | None = None,
) -> list[GainChoice]:
    """Every gain of a condition's loop that gives ``phase_margin`` deg, ordered by
    crossover frequency, each with what else it changes in the tableau; at the start
    values, or at ``named`` ones (the workbench's current design, as a record names them)."""
    from engine.design.gain_solves import phase_margin_solutions
    from engine.design.tableau import tableau

    problem = session.problem if named is None else _with_values(session.problem, named)
    name, values = _gain_of(session, condition, parameter, problem)
    c = problem.conditions[condition]
    try:
        solutions = phase_margin_solutions(loop_model(c.network, c.break_at, problem.grid.omega, values), phase_margin)
        now = {(r.name, r.condition): r.satisfied for r in tableau(problem)}
        choices = []
        for solution in solutions:
            then = tableau(_scaled(problem, name, solution.factor, condition))
            breaks = tuple(r.name for r in then if now.get((r.name, r.condition)) and not r.satisfied)
            meets = tuple(r.name for r in then if now.get((r.name, r.condition)) is False and r.satisfied)
            choices.append(GainChoice(solution, name, values[name] * solution.factor, breaks, meets))
    except EngineError as exc:
        raise SessionError(f"pm={phase_margin:g}: {exc}") from None
    return choices


def default_choice(choices: list[GainChoice]) -> int:
    """The choice taken when none is picked: the first (lowest crossover) that keeps every
    met requirement met, else the lowest crossover's."""
    return next((k for k, choice in enumerate(choices) if not choice.breaks), 0)


def _with_values(problem: Problem, named: Mapping[str, float | Sequence[float]]) -> Problem:
    """The problem with the parameters ``named`` at those values."""
    from dataclasses import replace

    def value(v: float | Sequence[float]) -> float | tuple[float, ...]:
        return float(v) if isinstance(v, (int, float)) else tuple(float(x) for x in v)

    parameters = tuple(replace(p, value=value(named[p.name])) if p.name in named else p for p in problem.parameters)
    return replace(problem, parameters=parameters)


def _scaled(problem: Problem, name: str, factor: float, condition: int) -> Problem:
    """The problem with the gain parameter ``name`` scaled (in ``condition`` alone when per condition)."""
    from dataclasses import replace

    def scaled(value: float | tuple[float, ...]) -> float | tuple[float, ...]:
        if isinstance(value, tuple):
            return tuple(v * factor if k == condition else v for k, v in enumerate(value))
        return value * factor

    parameters = tuple(replace(p, value=scaled(p.value)) if p.name == name else p for p in problem.parameters)
    return replace(problem, parameters=parameters)


def tune(
    session: Session, goal: str, target: float, parameter: str | None, condition: int, pick: int | None = None
) -> tuple[GainSolution, str, list[GainChoice], int | None]:
    """Solve the loop gain of a condition for ``goal`` ("crossover", rad/s, or "pm", deg)
    and scale the gain parameter by it, in that condition alone when it is per condition
    (the design on screen first made the start): the solution, what changed, and for a
    phase margin every choice with the index of the one taken (``pick``, 1-based in
    frequency order; default `default_choice`)."""
    adopt_current(session)
    before = session.model.problem.model_copy(deep=True)
    choices: list[GainChoice] = []
    index: int | None = None
    if goal == "pm":
        choices = phase_margin_choices(session, condition, target, parameter)
        if pick is not None and not 1 <= pick <= len(choices):
            raise SessionError(f"--pick {pick}: pm={target:g} has {len(choices)} solution(s), 1..{len(choices)}")
        index = default_choice(choices) if pick is None else pick - 1
        name, solution = choices[index].parameter, choices[index].solution
    else:
        name, solution = solved_gain(session, condition, goal, target, parameter)
    with committed(session, before, {name: f"--gain-for {goal}={target:g}"}):
        line = _set(session, name, lambda v: v * solution.factor, condition)
        rebuild(session, start_checked=False)
    note_edit(session, before)
    return solution, line, choices, index


def solved_gain(
    session: Session, condition: int, goal: str, target: float, parameter: str | None = None
) -> tuple[str, GainSolution]:
    """The gain parameter of a condition's loop at the start values (``parameter``, checked,
    else the one the loop is proportional to) and the solution for ``goal`` (`gain_for`)."""
    problem = session.problem
    name, values = _gain_of(session, condition, parameter)
    c = problem.conditions[condition]
    try:
        return name, gain_for(loop_model(c.network, c.break_at, problem.grid.omega, values), goal, target)
    except EngineError as exc:
        raise SessionError(f"{goal}={target:g}: {exc}") from None


def _gain_of(
    session: Session, condition: int, parameter: str | None, problem: Problem | None = None
) -> tuple[str, dict[str, float]]:
    """The gain parameter of a condition's loop (``parameter``, checked, else the one the
    loop is proportional to) and the condition's values (the session's start, or ``problem``'s)."""
    problem = session.problem if problem is None else problem
    if not 0 <= condition < len(problem.conditions):
        raise SessionError(f"condition {condition} is outside 0..{len(problem.conditions) - 1}")
    values = problem.condition_values(condition)
    if parameter is not None and not _scales(session, condition, values, parameter):
        raise SessionError(f"--parameter {parameter}: the loop is not proportional to it (no such gain)")
    return parameter or gain_parameter(session, condition, values), values


def _set(session: Session, name: str, change, condition: int | None = None) -> str:
    """Change a parameter's start value (each condition's, or one condition's), its bounds
    checked with the whole change (`committed`): the line that says what changed."""
    parameters = {p.name: p for p in session.model.problem.parameters}
    if name not in parameters:
        raise SessionError(f"{name}: no such parameter; the session has {', '.join(parameters)}")
    p = parameters[name]
    old = p.value
    if isinstance(old, list):
        new = [change(v) if condition in (None, k) else v for k, v in enumerate(old)]
    else:
        new = change(old)
    for v in new if isinstance(new, list) else [new]:
        if not math.isfinite(v):
            raise SessionError(f"{name} = {v:g}: not a finite number (the float range ends at 1.8e308): not set")
    p.value = new
    return f"{name}: {value_text(old)} -> {value_text(new)}"


def gain_parameter(session: Session, condition: int, values: dict[str, float]) -> str:
    """The one parameter a condition's loop is proportional to at ``values`` (a refusal
    names the candidates, or says to write a gain)."""
    scaling = [p.name for p in session.model.problem.parameters if _scales(session, condition, values, p.name)]
    if len(scaling) != 1:
        name = session.problem.conditions[condition].name
        if not scaling:
            raise SessionError(
                f"no parameter scales the loop of {name}: write the compensator as K*(...) with a gain K"
            )
        raise SessionError(f"{', '.join(scaling)} all scale the loop of {name}: name the gain with --parameter")
    return scaling[0]


def _scales(session: Session, condition: int, values: dict[str, float], name: str) -> bool:
    """Does doubling ``name`` double the loop (at three of the grid's frequencies)?"""
    value = values.get(name)
    if not value or not math.isfinite(value):
        return False
    problem = session.problem
    c = problem.conditions[condition]
    w = problem.grid.omega[np.linspace(0, problem.grid.omega.size - 1, 3).astype(int)]
    try:
        before = loop_model(c.network, c.break_at, w, values).gh
        after = loop_model(c.network, c.break_at, w, {**values, name: 2 * value}).gh
    except EngineError:
        return False
    with np.errstate(all="ignore"):
        return bool(np.all(np.abs(after / before - 2.0) < LINEAR * 2))

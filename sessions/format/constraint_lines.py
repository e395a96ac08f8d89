"""The session's linear constraints between parameters (``problem.constraints``).

Each is one line of text, ``a1*p1 + a2*p2 + ... <= c`` (or ``>=``), read by
`engine.design.constraint_reader` (never evaluated by Python).  A name is a parameter's;
``name[condition]`` (a condition's name or index) picks one condition's value
of a parameter with a value per condition, and such a parameter written
without one makes the constraint hold in every condition.  A start that does
not meet a constraint is refused at load, naming it (as a value outside
[min, max] is): the algorithms then keep every constraint from the first
point on.

`check_constraint_line` is what an editor calls as a line is typed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import AfterValidator, Field

from engine.design.constraint_reader import MAX_LENGTH, LinearFormError, read_constraint
from engine.design.constraints import TOLERANCE, LinearInequality, unmet
from engine.errors import EngineError
from sessions.errors import SessionError

if TYPE_CHECKING:
    from engine.design.problem import Problem
    from sessions.format.schema import ProblemModel


def _readable(text: str) -> str:
    """The schema's check: the line reads as a linear inequality (names are checked at build)."""
    try:
        read_constraint(text)
    except LinearFormError as exc:
        raise ValueError(str(exc)) from None
    return text


ConstraintText = Annotated[str, Field(max_length=MAX_LENGTH), AfterValidator(_readable)]


def inequality(text: str, path: str, conditions: list[str]) -> LinearInequality:
    """The engine's inequality of one line; conditions in brackets resolved by name or index."""
    try:
        form = read_constraint(text)
    except LinearFormError as exc:
        raise SessionError(f"{path}: {exc}") from None
    terms = []
    for reference, coefficient in form.terms:
        condition = None
        if reference.label is not None:
            label = reference.label
            if label in conditions:
                condition = conditions.index(label)
            elif label.isdigit() and int(label) < len(conditions):
                condition = int(label)
            else:
                raise SessionError(
                    f"{path}: {reference}: no condition {label!r} (conditions: {', '.join(conditions) or 'none'})"
                )
        terms.append((reference.name, condition, coefficient))
    return LinearInequality(tuple(terms), form.bound, text)


def build_inequalities(model: ProblemModel) -> tuple[LinearInequality, ...]:
    """Every line of ``problem.constraints``; errors name the line's JSON path."""
    names = [c.name for c in model.conditions]
    return tuple(inequality(text, f"problem.constraints[{k}]", names) for k, text in enumerate(model.constraints))


def check_start(problem: Problem) -> None:
    """Refuse a start that does not meet a constraint, naming it and by how much."""
    found = unmet(problem, problem.vector(), " at the start")
    if found:
        index, _, rest = found[0].removeprefix("constraints[").partition("] ")
        raise SessionError(
            f"problem.constraints[{index}]: {rest}; change the parameters' values or the "
            "constraint (the design would otherwise start outside it)"
            + (f" (and {len(found) - 1} more)" if len(found) > 1 else "")
        )


def check_constraint_line(text: str, model: ProblemModel, index: int | None = None) -> LinearInequality:
    """One line as an editor checks it while it is typed: it reads as a linear inequality, names
    parameters of ``model`` (with conditions where they have one value per condition) and holds
    at their values.  ``index``: the line's place in the list (None: a new last line).  A
    `SessionError` names ``problem.constraints[index]`` and, for a reading error, the column."""
    where = f"problem.constraints[{len(model.constraints) if index is None else index}]"
    conditions = [c.name for c in model.conditions]
    found = inequality(text, where, conditions)
    parameters = {p.name: p for p in model.parameters}
    rows: list[tuple[float, float, str]] = []
    for name, c, _ in found.terms:
        p = parameters.get(name)
        if p is None:
            raise SessionError(f"{where}: unknown parameter {name!r} (parameters: {', '.join(parameters) or 'none'})")
        if c is not None and not isinstance(p.value, list):
            raise SessionError(f"{where}: {name!r} is shared by all conditions: write it without a condition")
    every = any(c is None and isinstance(parameters[n].value, list) for n, c, _ in found.terms)
    for condition in range(len(conditions)) if every else (None,):
        parts = [
            coefficient * _value(parameters[name].value, c if c is not None else condition)
            for name, c, coefficient in found.terms
        ]
        rows.append(
            (sum(parts), sum(map(abs, parts)), "" if condition is None else f" in condition {conditions[condition]!r}")
        )
    for left, size, label in rows:
        if left - found.bound > TOLERANCE * max(1.0, abs(found.bound), size):
            raise SessionError(
                f"{where}: {text!r} is not met{label} at the parameters' values: violated by "
                f"{left - found.bound:.3g} (as {found.normal}, the left side is {left:.6g})"
            )
    return found


def engine_error(exc: EngineError) -> SessionError:
    """An engine error about ``constraints[k]`` as a session error with its JSON path."""
    text = str(exc)
    return SessionError(f"problem.{text}" if text.startswith("constraints[") else f"problem: {text}")


def _value(value: float | list[float], condition: int | None) -> float:
    """A parameter's value in a condition (a shared one's in all)."""
    if not isinstance(value, list):
        return value
    return value[condition if condition is not None and condition < len(value) else 0]

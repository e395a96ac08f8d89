"""Linear inequality constraints between parameters, shared by the algorithms.

A `LinearInequality` is ``sum(coefficient * parameter) <= bound`` (a ``>=`` is
stored negated, `engine.design.constraint_reader`).  Over the free vector x it becomes rows
of ``A x <= b`` (`inequality_rows`): fixed parameters move into b at their
values; a term naming a parameter that has one value per condition without a
condition (``condition`` None) makes the constraint hold in every condition,
one row each; a term with a condition takes that condition's value.  Rows left
with no free parameter are kept out of A (they are checked at the start).

Here too: the check of a point (`unmet`), the projection of a point onto
``{A x <= b, lower <= x <= upper}`` with the least Euclidean change (`project`,
Lawson and Hanson's least-distance program by NNLS) and the smooth penalty qcg
adds to its cost (`penalty`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError, shortened

if TYPE_CHECKING:
    from engine.design.problem import Problem

TOLERANCE = 1e-9  # a row is met when A x - b <= TOLERANCE * its scale (`row_scale`)
BINDS = 1e-6  # `binding`: a row whose slack is within this (relative) of its scale binds
SLACK = 1e-12  # `project` leaves a point alone whose rows are met within this (relative)
PENALTY_WEIGHT = 1e8  # qcg: F (1 + weight * sum (violation / scale)^2)
PENALTY_MARGIN = 1e-7  # qcg: the violation counts from this far (relative) inside the boundary


@dataclass(frozen=True)
class LinearInequality:
    """sum coefficient * parameter <= bound; a term is (name, condition index or None, coefficient)."""

    terms: tuple[tuple[str, int | None, float], ...]
    bound: float
    text: str = ""

    @property
    def normal(self) -> str:
        """The stored form, e.g. ``-T1 + 4*T2 <= 0`` for ``T1 >= 4*T2``."""
        text = ""
        for name, condition, c in self.terms:
            size = "" if abs(c) == 1 else f"{abs(c):.12g}*"
            where = "" if condition is None else f"[{condition}]"
            text += ("-" if c < 0 else "") if not text else (" - " if c < 0 else " + ")
            text += f"{size}{name}{where}"
        return f"{text} <= {self.bound:.12g}"

    @property
    def label(self) -> str:
        """The constraint as written (at most 60 characters of it), for messages and records."""
        text = self.text or self.normal
        return shortened(text, 60)


@dataclass(frozen=True)
class Rows:
    """Every row of every inequality over the free vector: ``A x <= b``; ``origin`` is
    (inequality index, condition or None) of each row."""

    A: NDArray[np.float64]
    b: NDArray[np.float64]
    origin: tuple[tuple[int, int | None], ...]

    @property
    def free(self) -> NDArray[np.bool_]:
        """Rows that hold a free parameter."""
        return np.any(self.A != 0, axis=1)


def check_inequalities(problem: Problem) -> None:
    """Every term of every inequality names a parameter, with a condition only where it has one
    value per condition (none there: every condition); errors name ``constraints[k]``."""
    if problem.inequalities:
        by_name = {p.name: p for p in problem.parameters}
        for k, inequality in enumerate(problem.inequalities):
            _check(inequality, by_name, len(problem.conditions), f"constraints[{k}]")


def _check(inequality: LinearInequality, by_name: dict, conditions: int, where: str) -> None:
    for name, c, coefficient in inequality.terms:
        p = by_name.get(name)
        if p is None:
            raise EngineError(f"{where}: unknown parameter {name!r} (parameters: {', '.join(by_name) or 'none'})")
        if c is not None and not p.per_condition:
            raise EngineError(f"{where}: {name!r} is shared by all conditions: write it without a condition")
        if c is not None and not 0 <= c < conditions:
            raise EngineError(f"{where}: {name!r}: no condition {c}")
        if not np.isfinite(coefficient):
            raise EngineError(f"{where}: the coefficient of {name!r} is not finite")
    if not np.isfinite(inequality.bound):
        raise EngineError(f"{where}: the bound is not finite")


def inequality_rows(problem: Problem) -> Rows:
    """The rows of every inequality over ``problem``'s free vector (see the module docstring)."""
    slots = {(problem.parameters[i].name, c): k for k, (i, c) in enumerate(problem.free_slots())}
    by_name = {p.name: p for p in problem.parameters}
    rows, bounds, origin = [], [], []
    for k, inequality in enumerate(problem.inequalities):
        every = any(c is None and by_name[n].per_condition for n, c, _ in inequality.terms)
        for condition in range(len(problem.conditions)) if every else (None,):
            row, bound = np.zeros(len(slots)), inequality.bound
            for name, c, coefficient in inequality.terms:
                p = by_name[name]
                at = c if c is not None else (condition if p.per_condition else None)
                slot = slots.get((name, at))
                if slot is None:
                    bound -= coefficient * p.at(0 if at is None else at)
                else:
                    row[slot] += coefficient
            rows.append(row)
            bounds.append(bound)
            origin.append((k, condition if every else None))
    return Rows(
        np.array(rows, dtype=float).reshape(len(rows), len(slots)), np.array(bounds, dtype=float), tuple(origin)
    )


def row_scale(A: NDArray, b: NDArray, x: NDArray) -> NDArray:
    """The size a row's slack is measured against: max(1, |b|, sum |A_k x_k|)."""
    return np.maximum.reduce([np.ones(b.size), np.abs(b), np.abs(A) @ np.abs(x)])


def _slack(problem: Problem, x: NDArray) -> tuple[Rows, NDArray, NDArray]:
    """Every row of ``problem``'s inequalities at ``x``: the rows, their slack b - A x (negative:
    violated) and the size it is measured against (`row_scale`)."""
    rows = inequality_rows(problem)
    return rows, rows.b - rows.A @ x, row_scale(rows.A, rows.b, x)


def unmet(problem: Problem, x: NDArray, when: str = "") -> list[str]:
    """A line for every row not met at ``x`` (within `TOLERANCE`), naming its constraint
    (``when``, e.g. " at the start", follows "is not met")."""
    return [line for _, line in violations(problem, x, when)]


def violations(problem: Problem, x: NDArray, when: str = "") -> list[tuple[int, str]]:
    """`unmet`'s lines, each with the index of its inequality."""
    rows, slack, scale = _slack(problem, x)
    excess = -slack
    out = []
    for r in np.flatnonzero(excess > TOLERANCE * scale):
        k, condition = rows.origin[r]
        where = "" if condition is None else f" in condition {problem.conditions[condition].name!r}"
        inequality = problem.inequalities[k]
        left = rows.A[r] @ x + (inequality.bound - rows.b[r])
        out.append(
            (
                k,
                f"constraints[{k}] {inequality.label!r} is not met{where}{when}: violated by {excess[r]:.3g} "
                f"(as {inequality.normal}, the left side is {left:.6g})",
            )
        )
    return out


def check_change(problem: Problem, changed: Mapping[str, str]) -> None:
    """A change of parameters' values (a command's assignments, an edit's fields) checked once,
    as a whole, at the problem's new start: every value within its bounds, every linear
    constraint met.  ``changed``: each changed parameter's name -> the assignment that changed
    it; an `EngineError` names the assignment and the bound or the constraint."""
    for p in problem.parameters:
        for value in p.value if p.per_condition else (p.value,):
            side = "below" if value < p.lower() else "above" if value > p.upper() else ""
            if side:
                bound, which = (p.lower(), "min") if side == "below" else (p.upper(), "max")
                where = changed.get(p.name, p.name)
                raise EngineError(f"{where}: {p.name} = {value:.6g} is {side} its bound {bound:g} ({which}): not set")
    rows = violations(problem, problem.vector(), " after the change")
    if rows:
        k, line = rows[0]
        named = {name for name, _, _ in problem.inequalities[k].terms}
        by = [text for name, text in changed.items() if name in named] or list(dict.fromkeys(changed.values()))
        more = f" (and {len(rows) - 1} more)" if len(rows) > 1 else ""
        raise EngineError(f"{', '.join(dict.fromkeys(by))}: {line}{more}: not set")


def binding(problem: Problem, x: NDArray, within: float = BINDS) -> list[str]:
    """The constraints that bind at ``x``: each row at its bound within ``within`` of its
    scale (`row_scale`), named as written (``'T1 <= 20*T2' binds``), once per constraint
    (with its condition where it holds in each)."""
    rows, slack, scale = _slack(problem, x)
    out = []
    for r in np.flatnonzero(slack <= within * scale):
        k, condition = rows.origin[r]
        where = "" if condition is None else f" in {problem.conditions[condition].name!r}"
        out.append(f"{problem.inequalities[k].label!r} binds{where}")
    return list(dict.fromkeys(out))


@dataclass(frozen=True)
class ConstraintState:
    """A linear constraint at a design: its least slack over its rows (b - A x: negative when
    violated) and in a word whether it binds (within `BINDS`), holds or is violated."""

    slack: float
    state: str  # "binds", "holds" or "VIOLATED"


def constraint_states(problem: Problem, x: NDArray) -> list[ConstraintState]:
    """Each of ``problem.inequalities`` at the free vector ``x`` (a constraint that holds in every
    condition is judged on its worst one)."""
    rows, slack, scale = _slack(problem, x)
    out = []
    for k in range(len(problem.inequalities)):
        mine = [r for r, (origin, _) in enumerate(rows.origin) if origin == k]
        worst = min(mine, key=lambda r: slack[r] / scale[r])
        state = (
            "VIOLATED"
            if slack[worst] < -TOLERANCE * scale[worst]
            else "binds"
            if slack[worst] <= BINDS * scale[worst]
            else "holds"
        )
        out.append(ConstraintState(float(slack[worst]), state))
    return out


def check_start(problem: Problem, x: NDArray, who: str) -> None:
    """An `EngineError` naming the first constraint ``x`` does not meet."""
    found = unmet(problem, x, " at the start")
    if found:
        raise EngineError(f"{who}: {found[0]}" + (f" (and {len(found) - 1} more)" if len(found) > 1 else ""))


def project(z: NDArray, A: NDArray, b: NDArray, lower: NDArray, upper: NDArray, slack: float = SLACK) -> NDArray:
    """The point of {A x <= b, lower <= x <= upper} nearest ``z`` (Euclidean); ``z`` clipped to
    the bounds when that meets every row within ``slack`` (relative, `row_scale`), so without
    constraints it is the clip.  An `EngineError` when the set is empty."""
    clipped = np.clip(z, lower, upper)
    if not b.size or np.all(A @ clipped - b <= slack * row_scale(A, b, clipped)):
        return clipped
    n = z.size
    eye = np.eye(n)
    low, high = np.isfinite(lower), np.isfinite(upper)
    G = np.vstack([-A, eye[low], -eye[high]])  # G d >= h for the move d = x - z
    h = np.concatenate([A @ z - b, lower[low] - z[low], z[high] - upper[high]])
    norms = np.maximum(np.linalg.norm(G, axis=1), 1e-300)
    G, h = G / norms[:, None], h / norms
    E = np.vstack([G.T, h[None, :]])
    f = np.zeros(n + 1)
    f[-1] = 1.0
    from scipy.optimize import nnls  # on use: scipy.optimize costs ~130 ms at every start

    u, _ = nnls(E, f, maxiter=50 * (E.shape[1] + 1))
    r = E @ u - f
    if not np.isfinite(r).all() or abs(r[-1]) <= 1e-12:
        raise EngineError("the linear constraints cannot be met within the parameters' bounds")
    x = np.clip(z - r[:n] / r[-1], lower, upper)
    if np.any(A @ x - b > TOLERANCE * row_scale(A, b, x)):
        raise EngineError("the linear constraints cannot be met within the parameters' bounds")
    return x


def penalty(A: NDArray, b: NDArray, scale: NDArray, x: NDArray) -> tuple[float, NDArray]:
    """sum (max(0, A x - b + PENALTY_MARGIN scale) / scale)^2 and its gradient in x: 0 wherever
    every row is met with the margin; the margin puts a penalized optimum on the feasible side."""
    v = np.maximum((A @ x - b) / scale + PENALTY_MARGIN, 0.0)
    return float(v @ v), 2.0 * A.T @ (v / scale)

"""cip with the problem's linear constraints A x <= b: hard constraints of the step.

The report holds a coefficient at a bound that the direction would push
through and recomputes D without it (direction.py).  A linear constraint is
held the same way: when D would push an active row (within `hold_tolerance`
of its bound) outward, D is recomputed in the null space of the held rows
(and of the coefficients held at their bounds), D = N (G N)'((G N)(G N)')^-1 c
with N an orthonormal basis of that null space; with no row blocked D is the
report's, unchanged.  The trial point x + h D is then projected onto
{A x <= b, min <= x <= max} with the least change (`engine.design.constraints.project`),
which is the report's clip to the bounds when no row is crossed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.cip.direction import DEPENDENT, ZERO, Direction, Rows, at_bound, improvement_direction
from engine.design.constraints import inequality_rows, project, row_scale
from engine.design.problem import Problem


@dataclass(frozen=True)
class HeldDirection(Direction):
    """A direction with the linear constraints it holds (their rows' indices in A)."""

    held_rows: tuple[int, ...] = ()


def held_direction(
    rows: Rows,
    x: NDArray,
    lower: NDArray,
    upper: NDArray,
    hold_tolerance: float,
    labels: list[str],
    A: NDArray,
    b: NDArray,
) -> HeldDirection:
    """The report's direction, recomputed with the active rows of A x <= b it would cross held."""
    first = improvement_direction(rows, x, lower, upper, hold_tolerance, labels)
    active = _active_rows(A, b, x, hold_tolerance)
    if first.vector is None or not _crossing(A, first.vector, active, set()):
        return HeldDirection(first.vector, first.held, first.termination, first.reason)
    unit = rows.gradients / np.linalg.norm(rows.gradients, axis=1)[:, None]
    held, held_rows = first.held.copy(), set(_crossing(A, first.vector, active, set()))
    for _ in range(x.size + len(active) + 1):  # each pass holds one more coefficient or row
        found = _reduced(unit, rows.weights, held, A[sorted(held_rows)])
        if isinstance(found, HeldDirection):
            return HeldDirection(None, held, found.termination, found.reason, tuple(sorted(held_rows)))
        blocked = ~held & (
            (at_bound(x, lower, hold_tolerance) & (found < 0)) | (at_bound(x, upper, hold_tolerance) & (found > 0))
        )
        crossing = _crossing(A, found, active, held_rows)
        if not blocked.any() and not crossing:
            return HeldDirection(found / np.linalg.norm(found), held, held_rows=tuple(sorted(held_rows)))
        held |= blocked
        held_rows |= set(crossing)
    return HeldDirection(
        None, held, "dependent", "the held coefficients and constraints leave no direction", tuple(sorted(held_rows))
    )


def _reduced(unit: NDArray, weights: NDArray, held: NDArray, rows: NDArray) -> NDArray | HeldDirection:
    """D in the null space of the held coordinates and rows, or why there is none."""
    H = np.vstack([np.eye(held.size)[held], rows.reshape(-1, held.size)])
    N = _null_space(H) if H.shape[0] else np.eye(held.size)
    G = unit @ N
    if N.shape[1] == 0 or np.any(np.linalg.norm(G, axis=1) <= ZERO):
        return HeldDirection(
            None,
            held,
            "zero_gradient",
            "a gradient is zero once the coefficients at their bounds and the linear constraints at theirs are held",
        )
    if G.shape[0] > G.shape[1]:
        return HeldDirection(
            None,
            held,
            "theorem2",
            f"{G.shape[0]} active requirements (margins x points) but only {G.shape[1]} "
            "directions left by the bounds and linear constraints held: improvement cannot "
            "be assured (report 000, Theorem 2)",
        )
    singular = np.linalg.svd(G, compute_uv=False)
    if singular[-1] <= DEPENDENT * singular[0]:
        return HeldDirection(
            None,
            held,
            "dependent",
            "the gradients of the active requirements are linearly "
            f"dependent in the directions the held linear constraints leave "
            f"(singular values {singular[0]:.3g} .. {singular[-1]:.3g})",
        )
    return N @ (G.T @ np.linalg.solve(G @ G.T, weights))


def _active_rows(A: NDArray, b: NDArray, x: NDArray, tolerance: float) -> list[int]:
    """Rows of A x <= b within ``tolerance`` (relative, `row_scale`) of their bound."""
    if not b.size:
        return []
    return np.flatnonzero(b - A @ x <= tolerance * row_scale(A, b, x)).tolist()


def _crossing(A: NDArray, d: NDArray, active: list[int], held: set[int]) -> list[int]:
    """Active rows not yet held that ``d`` would push outward."""
    return [r for r in active if r not in held and A[r] @ d > ZERO * np.linalg.norm(A[r]) * np.linalg.norm(d)]


def trial_point(x: NDArray, h: float, d: NDArray, A: NDArray, b: NDArray, lower: NDArray, upper: NDArray) -> NDArray:
    """x + h d projected onto the bounds and A x <= b (the clip when no row is crossed)."""
    return project(x + h * d, A, b, lower, upper)


def held_labels(problem: Problem, direction: Direction) -> list[str]:
    """The constraints whose rows ``direction`` holds, as written (for the record's ``held``)."""
    held = getattr(direction, "held_rows", ())
    if not held:
        return []
    rows = inequality_rows(problem)
    origin = [o for o, free in zip(rows.origin, rows.free) if free]
    return [problem.inequalities[k].label for k in sorted({origin[r][0] for r in held})]


def _null_space(matrix: NDArray) -> NDArray:
    """scipy's null space, imported on first use (scipy.linalg costs a tenth of a second of the
    workbench's start on a cip session, whose first paint needs none of it)."""
    from scipy.linalg import null_space

    return null_space(matrix)

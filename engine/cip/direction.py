"""The constraint-improvement direction of report 000 (chapter IV, listing
PARCLT and DIRVEC).

Each active margin is moved relative to its push or pull points: the
requirement is the squared distance d(w) = |GH(jw) - q|^2 at the margin's
frequency, to be increased (push) or decreased (pull).  Its gradient with
respect to the free coefficients comes from the engine's analytic
sensitivities, d d / d p = 2 Re(conj(GH - q) dGH/dp); `partials.py` has the
report's closed form (5-9)..(5-19), which the tests compare.  Rows are scaled
to unit length as CIP does.  The direction is D = G'(G G')^-1 c with G the
matrix of unit gradient rows and c the weights (all ones in the report).

Coefficients at a bound that the direction would push through are held and
their columns removed, then D is recomputed (the listing's loop at 423-431,
there for coefficients at zero).

The report's rows hold each margin's frequency fixed.  A gain or phase margin
sits at a crossing that moves with the design, so its distance can fall
where the fixed-frequency row says it rises (a lone gain: raising K pushes
GH(j w_c) away from -1 while the phase margin at the new crossover shrinks).
``tracking`` rows add the crossing's motion, dGH/domega domega/dx, with
domega/dx from the crossing's condition (Im GH = 0 at a phase crossover,
|GH| = 1 at a gain crossover), as slp's partials do; the stepper uses them
when the report's rows find no accepted step (algorithm.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.cip.requirements import Requirement
from engine.design.problem import Problem
from engine.loop.evaluator import LoopEvaluator
from engine.loop.responses import crossing_motion, open_loop

# the directions a step may take, as records name them (`extra["direction"]`)
REPORT = "the report's direction"
MOVING = "the direction with the crossings moving"  # rows whose crossings move with the design
COMPROMISE = "the least-squares compromise"  # tried where the report stops on Theorem 2

DEPENDENT = 1e-7  # smallest/largest singular value of G below this: dependent gradients
ZERO = 1e-12  # relative size of a gradient treated as zero


@dataclass(frozen=True)
class Rows:
    """Raw gradient rows (one per active margin and point), their weights,
    the requirement each row belongs to, and the squared distances."""

    gradients: NDArray[np.float64]
    weights: NDArray[np.float64]
    owners: tuple[int, ...]
    distances: NDArray[np.float64]


@dataclass(frozen=True)
class Direction:
    """A unit direction over the free vector, or why there is none."""

    vector: NDArray[np.float64] | None
    held: NDArray[np.bool_]
    termination: str = ""
    reason: str = ""


def gradient_rows(problem: Problem, x: NDArray, active: list[Requirement], tracking: bool = False) -> Rows:
    """Gradients of d(w) for every active requirement and each of its points, each on the loop
    at its break (`Requirement.loop_break`); with ``tracking``, a margin at a crossing of an exact
    loop moves with its crossing (the module docstring)."""
    slot_of = problem.slot_index
    m = len(problem.free_slots())
    rows, weights, owners, distances = [], [], [], []
    for c, at in dict.fromkeys((con.condition, con.loop_break) for con in active):
        condition = problem.conditions[c]
        mine = [(k, con) for k, con in enumerate(active) if (con.condition, con.loop_break) == (c, at)]
        freqs = np.unique([con.frequency for _, con in mine])
        params, loop_break = problem.condition_values(c, x), at or condition.break_at
        response = open_loop(condition.network, loop_break, freqs, params, check=False)
        moving = tracking and condition.network.exact
        slopes = LoopEvaluator(condition.network, loop_break, params)(freqs)[1] if moving else None
        columns = [slot_of.get((name, c)) for name in response.parameters]
        used = np.array([j for j, slot in enumerate(columns) if slot is not None], dtype=int)
        slots = np.array([columns[j] for j in used], dtype=int)
        for k, con in mine:
            f = int(np.searchsorted(freqs, con.frequency))
            gh = response.value[f]
            dgh = response.sensitivity[f] if response.sensitivity is not None else np.zeros(0)
            if slopes is not None:
                dgh = dgh + slopes[f] * _moving(con, gh, dgh, slopes[f])
            for point in con.points:
                sign = 1.0 if point.mode == "push" else -1.0
                partial = 2.0 * np.real(np.conj(gh - point.value) * dgh) * sign
                row = np.zeros(m)
                if used.size:
                    np.add.at(row, slots, partial[used])
                rows.append(row)
                weights.append(con.weight)
                owners.append(k)
                distances.append(abs(gh - point.value) ** 2)
    return Rows(np.array(rows).reshape(len(rows), m), np.array(weights), tuple(owners), np.array(distances))


def _moving(requirement: Requirement, gh: complex, gh_x: NDArray, gh_w: complex) -> NDArray:
    """d omega / dx of the crossing a requirement sits at (`crossing_motion`); zero for a margin at an
    extremum of its distance, where the frequency's motion changes nothing to first order, and at
    omega = 0."""
    crossing = requirement.family.partition("<")[2] or requirement.kind
    if requirement.frequency <= 0 or crossing not in ("G", "P") or gh_x.size == 0:
        return np.zeros(gh_x.size)
    return crossing_motion(crossing, gh, gh_x, gh_w)


def improvement_direction(
    rows: Rows, x: NDArray, lower: NDArray, upper: NDArray, hold_tolerance: float, labels: list[str]
) -> Direction:
    """D = G'(G G')^-1 c over unit gradient rows, with coefficients held at bounds."""
    norms = np.linalg.norm(rows.gradients, axis=1)
    scale = np.maximum(np.abs(x), 1.0)
    zero = np.linalg.norm(rows.gradients * scale, axis=1) <= ZERO * np.maximum(rows.distances, 1e-300)
    held = np.zeros(x.size, dtype=bool)
    if zero.any():
        return Direction(None, held, "zero_gradient", _zero_reason(rows, zero, labels))
    unit = rows.gradients / norms[:, None]
    while True:
        free = ~held
        G = unit[:, free]
        if np.any(np.linalg.norm(G, axis=1) <= ZERO):
            return Direction(
                None, held, "zero_gradient", "a gradient is zero once the coefficients at their bounds are held"
            )
        if G.shape[0] > G.shape[1]:
            return Direction(
                None,
                held,
                "theorem2",
                f"{G.shape[0]} active requirements (margins x points) but only {G.shape[1]} "
                "free coefficients: improvement cannot be assured (report 000, Theorem 2)",
            )
        singular = np.linalg.svd(G, compute_uv=False)
        if singular[-1] <= DEPENDENT * singular[0]:
            return Direction(
                None,
                held,
                "dependent",
                "the gradients of the active requirements are linearly dependent "
                f"(singular values {singular[0]:.3g} .. {singular[-1]:.3g})",
            )
        a = np.linalg.solve(G @ G.T, rows.weights)
        d = np.zeros(x.size)
        d[free] = G.T @ a
        blocked = free & (
            (at_bound(x, lower, hold_tolerance) & (d < 0)) | (at_bound(x, upper, hold_tolerance) & (d > 0))
        )
        if not blocked.any():
            return Direction(d / np.linalg.norm(d), held)
        held |= blocked


def compromise_direction(rows: Rows, x: NDArray, lower: NDArray, upper: NDArray, hold_tolerance: float) -> Direction:
    """Beyond Theorem 2 (more active rows than free coefficients, where the report stops): the
    least-squares D of G D = 1 over the distances' own gradients, d|GH - q|/dx (not unit rows, so
    that its first-order gain c'G D = |P c|^2 >= 0 is a gain of the sum SIFR accepts on), with
    coefficients held at the bounds it would push through."""
    G = rows.gradients / (2.0 * np.sqrt(np.maximum(rows.distances, 1e-300)))[:, None]
    held = np.zeros(x.size, dtype=bool)
    for _ in range(x.size):
        d = np.zeros(x.size)
        d[~held] = np.linalg.lstsq(G[:, ~held], np.ones(G.shape[0]), rcond=None)[0]
        blocked = ~held & (
            (at_bound(x, lower, hold_tolerance) & (d < 0)) | (at_bound(x, upper, hold_tolerance) & (d > 0))
        )
        if not blocked.any():
            norm = np.linalg.norm(d)
            return Direction(d / norm if norm > 0 else None, held)
        held |= blocked
    return Direction(None, held)


def at_bound(x: NDArray, bound: NDArray, tolerance: float) -> NDArray[np.bool_]:
    """x is within ``tolerance`` (relative above 1) of a finite bound."""
    finite = np.isfinite(bound)
    gap = np.abs(x - np.where(finite, bound, 0.0))
    return finite & (gap <= tolerance * np.maximum(1.0, np.abs(np.where(finite, bound, 0.0))))


def _zero_reason(rows: Rows, zero: NDArray, labels: list[str]) -> str:
    owner = rows.owners[int(np.flatnonzero(zero)[0])]
    return (
        f"the gradient of {labels[owner]} is zero: no free coefficient moves it "
        "(a relative extremum, report 000 chapter IV)"
    )

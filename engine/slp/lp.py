"""One linear program of COEBRA (report 003, eqs. 2-9 to 2-14), solved by HiGHS.

Over the step dx from the major iteration's point x0:
  maximize    c' dx                       (Y1 or -Y2, built by the caller)
  subject to  g_i' dx >= Mt_i - M_i       for every requirement row i, with
              Mt_i = SPEC_i if the row is met at x0, else M_i + STEP (SPEC_i - M_i)
              (optionally SPEC_i plus a small back-off for met rows, see solve_step)
              max(lo - x0, -P r) <= dx <= min(hi - x0, P r),  r = max(|x0|, floor)
              A_eq (x0 + dx) = b_eq
              A_in dx <= b_in - A_in x0    (the problem's linear constraints, A_in x <= b_in)
All rows are in the "larger is better" orientation (at-most rows negated).
The inner loop lowers STEP (1, 0.8, ..., 0) until the program is feasible.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

STATUS_TEXT = {0: "optimal", 1: "iteration limit", 2: "infeasible", 3: "unbounded", 4: "numerical difficulties"}


@dataclass(frozen=True)
class LpResult:
    """The step (None when no STEP gave a solvable program), the STEP used, how
    many programs were solved, HiGHS's last status, and the duals of the rows."""

    dx: NDArray[np.float64] | None
    step: float
    solves: int
    status: str
    duals: NDArray[np.float64]


def step_box(x0: NDArray, lower: NDArray, upper: NDArray, P: float, floor: float) -> tuple[NDArray, NDArray]:
    """Bounds on dx: +-P |x0| (eq. 2-13), within each variable's min and max; |x0| is
    raised to ``floor`` times the variable's range (its bounds' span, else 1) so that
    a variable at zero can move (the report's box, floor 0, freezes it)."""
    span = np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    reach = P * np.maximum(np.abs(x0), floor * span)
    return np.maximum(lower - x0, -reach), np.minimum(upper - x0, reach)


def solve_step(
    c: NDArray,
    gradients: NDArray,
    values: NDArray,
    specs: NDArray,
    box: tuple[NDArray, NDArray],
    equalities: tuple[NDArray, NDArray],
    x0: NDArray,
    steps: NDArray,
    backoff: float = 0.0,
    inequalities: tuple[NDArray, NDArray] | None = None,
) -> LpResult:
    """The inner loop: the first STEP in ``steps`` whose program HiGHS solves.

    ``gradients``/``values``/``specs``: the requirement rows (oriented).  A met
    row is held at SPEC + ``backoff`` |SPEC| (or where it is, if lower), so the
    linearization's error at the vertex does not tip it over SPEC.  ``inequalities``:
    (A_in, b_in) of the problem's linear constraints, rows after the requirements'.
    """
    from scipy.optimize import linprog  # on first use: scipy.optimize costs a quarter of a second of start-up

    trouble = _unsolvable(c, gradients, values, specs, box, equalities)
    if trouble:
        return LpResult(None, float(steps[-1]), 0, trouble, np.zeros(len(values)))
    met = values >= specs
    held = np.minimum(values, specs + backoff * np.maximum(np.abs(specs), 1e-2))
    A_in, b_in = inequalities if inequalities is not None else (np.zeros((0, x0.size)), np.zeros(0))
    A_ub = np.vstack([-gradients.reshape(len(values), x0.size), A_in])
    A_eq, b_eq = equalities
    eq = dict(A_eq=A_eq, b_eq=b_eq - A_eq @ x0) if A_eq.size else {}
    status, solves = "not solved", 0
    for step in steps:
        wanted = np.where(met, held, values + step * (specs - values))
        b_ub = np.concatenate([values - wanted, b_in - A_in @ x0])
        result = linprog(
            -c,
            A_ub=A_ub if A_ub.size else None,
            b_ub=b_ub if A_ub.size else None,
            bounds=np.column_stack(box),
            method="highs",
            **eq,
        )
        solves += 1
        status = STATUS_TEXT.get(result.status, f"status {result.status}")
        if result.status == 0:
            duals = -result.ineqlin.marginals[: len(values)] if A_ub.size else np.zeros(0)
            return LpResult(np.asarray(result.x), float(step), solves, status, duals)
    return LpResult(None, float(steps[-1]), solves, status, np.zeros(len(values)))


def _unsolvable(
    c: NDArray,
    gradients: NDArray,
    values: NDArray,
    specs: NDArray,
    box: tuple[NDArray, NDArray],
    equalities: tuple[NDArray, NDArray],
) -> str:
    """Why no program can be posed ('' when one can): non-finite data, or an empty box."""
    for name, data in (
        ("objective", c),
        ("partials", gradients),
        ("measures", values),
        ("requirements", specs),
        ("equalities", equalities[0]),
        ("equality values", equalities[1]),
    ):
        if not np.all(np.isfinite(data)):
            return f"not posed: the {name} are not finite"
    lower, upper = box
    if np.any(np.isnan(lower) | np.isnan(upper)) or np.any(lower > upper):
        return "not posed: the step box is empty (a parameter outside its bounds)"
    return ""

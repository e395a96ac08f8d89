"""Partial derivatives of every measure row with respect to every free variable
(report 003, eq. 2-8: the first-order Taylor terms the LP is built from).

Two methods, named per row in the tableau:
  "analytic": from the engine's sensitivities dGH/dx (one batched solve per
      condition at the rows' frequencies) and dGH/domega, with the frequency
      of a crossing moving implicitly.  With L = ln GH = a + j phi:
        gain margin (dB) at a phase crossover: -20/ln10 (a_x - a_w phi_x / phi_w)
        phase margin (deg) at a gain crossover: 180/pi (phi_x - phi_w a_x / a_w)
        crossover frequency:                    -a_x / a_w
        modal peak (dB), a maximum of a:        20/ln10 a_x  (a_w = 0 there)
        attenuation (|GH| at a maximum):        |GH| a_x
        stability margin (a minimum of |1+GH|): Re(conj(1+GH) GH_x) / |1+GH|
        G/P distances |1+GH| at a crossing:     Re(conj(1+GH) (GH_x + GH_w w_x)) / |1+GH|
      The disk margin, Ms, Mt and the delay margin: slp/peaks.py.
  "finite difference": forward differences as the report does, for the
      other rows (time responses, the phase at a modal peak, stability
      abscissa, tabulated loops), re-evaluating only the conditions a
      variable enters.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from engine.design.problem import Problem
from engine.loop.responses import crossing_motion
from engine.slp.measures import Spec, evaluate
from engine.slp.peaks import analytic_row, closed_loop_row
from engine.slp.sensitivities import loop_sensitivities

ANALYTIC = (
    "gain_margin_db",
    "phase_margin_deg",
    "crossover_frequency",
    "modal_peak_db",
    "attenuation_margin",
    "stability_margin",
    "gain_margin",
    "phase_margin",
)
DB = 20.0 / math.log(10.0)


def jacobian(
    problem: Problem,
    x: NDArray,
    specs: Sequence[Spec],
    values: NDArray,
    frequencies: NDArray,
    method: str = "analytic",
    fd_step: float = 1e-6,
) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """(rows x free variables, the method used per row); absent rows get zero rows."""
    J = np.zeros((len(specs), len(x)))
    how = ["" if math.isnan(v) or math.isinf(v) else "finite difference" for v in values]
    if method == "analytic":
        for i in _analytic_rows(problem, x, specs, values, frequencies, J):
            how[i] = "analytic"
    numeric = [i for i, h in enumerate(how) if h == "finite difference"]
    if numeric:
        _finite_differences(problem, x, specs, values, numeric, J, fd_step)
    return J, tuple(how)


def _analytic_rows(
    problem: Problem, x: NDArray, specs: Sequence[Spec], values: NDArray, frequencies: NDArray, J: NDArray
) -> list[int]:
    """Fill the rows with analytic partials into J (the open loop's margins here, the closed-loop
    measures by `engine.slp.peaks`), each from its loop's sensitivities; the rows done."""
    margin_rows = [
        i for i, s in enumerate(specs) if s.kind in ANALYTIC and np.isfinite(values[i]) and np.isfinite(frequencies[i])
    ]
    peak_rows = [i for i, s in enumerate(specs) if analytic_row(s.kind, values[i], frequencies[i])]
    done: list[int] = []
    for _, _, rows, loop in loop_sensitivities(problem, x, specs, frequencies, margin_rows + peak_rows):
        for r, i in enumerate(rows):
            gh, gh_x, gh_w = loop.at(r)
            w = float(frequencies[i])
            if specs[i].kind in ANALYTIC:
                row = _row(specs[i].kind, gh, gh_x, gh_w, w > 0)
            else:
                row = closed_loop_row(specs[i].kind, gh, gh_x, gh_w, w, float(values[i]))
            loop.add(J, i, row)
            done.append(i)
    return done


def _row(kind: str, gh: complex, gh_x: NDArray, gh_w: complex, moving: bool) -> NDArray:
    """d(measure)/d(parameters) at a row's frequency (see the module docstring)."""
    L_x, L_w = gh_x / gh, gh_w / gh
    if kind == "gain_margin_db":
        return -DB * (L_x.real + (L_w.real * crossing_motion("G", gh, gh_x, gh_w) if moving else 0.0))
    if kind == "phase_margin_deg":
        return np.degrees(L_x.imag + L_w.imag * crossing_motion("P", gh, gh_x, gh_w))
    if kind == "crossover_frequency":
        return crossing_motion("P", gh, gh_x, gh_w)
    if kind == "modal_peak_db":
        return DB * L_x.real
    if kind == "attenuation_margin":
        return abs(gh) * L_x.real
    one = 1.0 + gh
    if kind == "stability_margin":
        return np.real(np.conj(one) * gh_x) / abs(one)
    if kind == "gain_margin":
        w_x = crossing_motion("G", gh, gh_x, gh_w) if moving else 0.0
    else:  # phase_margin: |GH| = 1
        w_x = crossing_motion("P", gh, gh_x, gh_w)
    return np.real(np.conj(one) * (gh_x + gh_w * w_x)) / abs(one)


def _finite_differences(
    problem: Problem, x: NDArray, specs: Sequence[Spec], values: NDArray, rows: list[int], J: NDArray, fd_step: float
) -> None:
    """Forward differences of the given rows, one perturbed evaluation per variable."""
    for j, (i_param, c_slot) in enumerate(problem.free_slots()):
        name = problem.parameters[i_param].name
        affected = [
            c
            for c, cond in enumerate(problem.conditions)
            if (c_slot is None or c == c_slot) and name in cond.network.parameters
        ]
        mine = [i for i in rows if specs[i].condition in affected]
        if not mine:
            continue
        h = fd_step * max(abs(x[j]), 1e-3)
        xh = np.array(x, dtype=float)
        xh[j] += h
        perturbed, _ = evaluate(problem, xh, [specs[i] for i in mine])
        for k, i in enumerate(mine):
            if np.isfinite(perturbed[k]):
                J[i, j] = (perturbed[k] - values[i]) / h

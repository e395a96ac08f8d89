"""The untrimmed open loop of report 004's reactor example, and the peaks of
bounded controls (the tableau's rows and the records' extra).

Open loop as the report computes it (Figure 7, max |u2| = 5.39e14): the
inputs named in the system's `open_loop` held at zero, the others solved
from E u + F x = 0 at each of the N + 1 sample points, and u held over each
step of the discrete model: x(k+1) = (Phi + Delta G) x(k), u(k) = G x(k).
(The continuous solution of the same DAE is a different curve: for the
reactor it peaks at 1.25e15 at 40 h, still growing; see
docs/algorithms/projection.md.)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.projection.lq import Trajectory
from engine.projection.system import DaeSystem
from engine.stepping.protocol import MeasureRow


def open_loop_gain(system: DaeSystem) -> NDArray:
    """G with u = G x: the zeroed inputs' rows 0, the others -E_f^-1 F (E_f: E's free columns)."""
    zero = set(system.open_loop or ())
    free = [j for j in range(system.m) if j + 1 not in zero]
    E_free = system.E[:, free]
    if E_free.shape[0] != E_free.shape[1] or np.linalg.matrix_rank(E_free) < len(free):
        raise EngineError(
            f"projection: with inputs {sorted(zero)} at zero, E u + F x = 0 must fix the other "
            f"{len(free)} inputs: needs {len(free)} independent algebraic equations, "
            f"has {system.E.shape[0]}"
        )
    G = np.zeros((system.m, system.n))
    G[free] = -np.linalg.solve(E_free, system.F)
    return G


def open_loop(system: DaeSystem, Phi: NDArray, Delta: NDArray) -> Trajectory:
    """The discrete open loop, x(k) = M^k x0 by doubling (log2 N matrix products, no loop per step)."""
    G = open_loop_gain(system)
    M = Phi + Delta @ G
    x, power = system.x0[None, :], M
    while x.shape[0] < system.steps + 1:
        x = np.vstack([x, x @ power.T])  # rows M^L .. M^(2L-1) x0 from rows M^0 .. M^(L-1) x0
        power = power @ power
    x = x[: system.steps + 1]
    return Trajectory(x, x @ G.T)


def peak_inputs(system: DaeSystem) -> list[int]:
    """Inputs (0-based) with a finite symmetric bound |u_j| <= b: the ones whose peak is reported."""
    lo, hi = system.u_lower, system.u_upper
    return [j for j in range(system.m) if np.isfinite(hi[j]) and lo[j] == -hi[j]]


def peaks(system: DaeSystem, t: Trajectory) -> dict[str, dict[str, float]]:
    """{'u2': {'value': signed peak, 'time': s, 'bound': b}} for every input of `peak_inputs`."""
    times, out = system.times(), {}
    for j in peak_inputs(system):
        k = int(np.argmax(np.abs(t.u[:, j])))
        out[f"u{j + 1}"] = {"value": float(t.u[k, j]), "time": float(times[k]), "bound": float(system.u_upper[j])}
    return out


def peak_rows(system: DaeSystem, found: dict[str, dict[str, float]], kind: str, slack: float) -> list[MeasureRow]:
    """Tableau rows |uj| (at most the bound, met within `slack`), the time in the condition column."""
    unit, seconds = system.time_unit
    return [
        MeasureRow(
            f"|{name}|",
            kind,
            f"t={p['time'] / seconds:.4g} {unit}",
            abs(p["value"]),
            p["bound"],
            abs(p["value"]) <= p["bound"] + slack,
            at_least=False,
        )
        for name, p in found.items()
    ]

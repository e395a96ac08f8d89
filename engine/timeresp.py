"""Time responses of a rational interconnection and their classical measures
(report 003, section 1.3): rise time 10-90 %, delay time 50 %, peak time,
overshoot, settling time (band, default 5 %), steady-state error, peak |x|.

Inputs are piecewise linear (steps, ramps and sequences of them, e.g. a wind
profile); the state equation is integrated exactly for such inputs with the
first-order-hold discretization exp([[A, B, 0], [0, 0, I], [0, 0, 0]] h).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import expm

from .errors import EngineError
from .realization import StateSpace


@dataclass(frozen=True)
class Segment:
    """From ``time`` on, the input adds ``step`` at once and then ramps at ``slope`` per second."""

    time: float
    step: float = 0.0
    slope: float = 0.0


def input_profile(t: NDArray, segments: Sequence[Segment]) -> NDArray:
    """Sum of steps and ramps: u(t) = sum_k H(t - t_k)(step_k + slope_k (t - t_k))."""
    u = np.zeros_like(t)
    for seg in segments:
        on = t >= seg.time
        u[on] += seg.step + seg.slope * (t[on] - seg.time)
    return u


def simulate(ss: StateSpace, input_name: str, t: ArrayLike, segments: Sequence[Segment]) -> NDArray:
    """All signals (len(t), n_signals) for the given input profile, zero initial state.

    Grid points are added at every breakpoint so the hold is exact.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0) or t[0] != 0:
        raise EngineError("time grid must start at 0 and increase strictly")
    if input_name not in ss.inputs:
        raise EngineError(f"unknown input {input_name!r}; inputs are {', '.join(ss.inputs)}")
    k = ss.inputs.index(input_name)
    breaks = [s.time for s in segments if 0 < s.time < t[-1]]
    grid = np.unique(np.concatenate([t, breaks]))
    u = input_profile(grid, segments)
    # the value just before a breakpoint is the left limit of the input
    u_left = np.where(np.isin(grid, breaks), input_profile(np.nextafter(grid, -np.inf), segments), u)
    B, D = ss.B[:, k], ss.D[:, k]
    n = ss.A.shape[0]
    x = np.zeros((grid.size, n))
    holds: dict[float, tuple[NDArray, NDArray, NDArray]] = {}
    for i in range(grid.size - 1):
        h = grid[i + 1] - grid[i]
        key = round(h, 12 - int(np.floor(np.log10(h))))  # equal steps of a linspace differ in the last bits
        if key not in holds:
            holds[key] = _foh(ss.A, B, h)
        Phi, Gam0, Gam1 = holds[key]
        du = (u_left[i + 1] - u[i]) / h
        x[i + 1] = Phi @ x[i] + Gam0 * u[i] + Gam1 * du
    y = x @ ss.C.T + np.outer(u, D)
    keep = np.isin(grid, t)
    return y[keep]


def _foh(A: NDArray, B: NDArray, h: float) -> tuple[NDArray, NDArray, NDArray]:
    """Exact one-step maps for an input linear over [0, h]: x+ = Phi x + G0 u0 + G1 du."""
    n = A.shape[0]
    big = np.zeros((n + 2, n + 2))
    big[:n, :n], big[:n, n], big[n, n + 1] = A * h, B * h, 1.0
    E = expm(big)
    return E[:n, :n], E[:n, n], E[:n, n + 1] * h


@dataclass(frozen=True)
class StepMeasures:
    """Classical measures of a response to a step toward ``final``."""

    final: float
    rise_time: float | None
    delay_time: float | None
    peak_time: float | None
    peak: float
    overshoot_percent: float
    settling_time: float | None
    steady_state_error: float


def step_measures(t: NDArray, y: NDArray, final: float, desired: float = 1.0,
                  band: float = 0.05) -> StepMeasures:
    """Rise (10-90 %), delay (50 %), first peak, overshoot, settling within ``band``."""
    if final == 0 or not np.isfinite(final):
        raise EngineError("step measures need a finite, non-zero final value")
    r = y / final

    def first_crossing(level: float) -> float | None:
        idx = np.flatnonzero(r >= level)
        if idx.size == 0:
            return None
        i = idx[0]
        if i == 0:
            return float(t[0])
        return float(t[i - 1] + (level - r[i - 1]) * (t[i] - t[i - 1]) / (r[i] - r[i - 1]))

    t10, t90 = first_crossing(0.1), first_crossing(0.9)
    peaks = np.flatnonzero((r[1:-1] >= r[:-2]) & (r[1:-1] > r[2:]) & (r[1:-1] > 1.0)) + 1
    ipk = int(peaks[0]) if peaks.size else int(np.argmax(r))
    outside = np.flatnonzero(np.abs(r - 1.0) > band)
    settle = None
    if outside.size == 0:
        settle = float(t[0])
    elif outside[-1] < t.size - 1:
        settle = float(t[outside[-1] + 1])
    return StepMeasures(
        final=float(final),
        rise_time=None if t10 is None or t90 is None else t90 - t10,
        delay_time=first_crossing(0.5),
        peak_time=float(t[ipk]) if peaks.size else None,
        peak=float(y[ipk]),
        overshoot_percent=float(max(0.0, (r[ipk] - 1.0) * 100.0)) if peaks.size else 0.0,
        settling_time=settle,
        steady_state_error=float(desired - final),
    )


def dc_gain(ss: StateSpace, input_name: str) -> NDArray:
    """Final value of every signal for a unit step at ``input_name`` (stable systems)."""
    k = ss.inputs.index(input_name)
    if ss.A.size == 0:
        return ss.D[:, k]
    return ss.D[:, k] - ss.C @ np.linalg.solve(ss.A, ss.B[:, k])


def peak_absolute(t: NDArray, y: NDArray) -> tuple[float, float]:
    """(time, value) of the largest |y|, e.g. peak angle of attack under a wind profile."""
    i = int(np.argmax(np.abs(y)))
    return float(t[i]), float(np.abs(y[i]))

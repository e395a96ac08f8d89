"""The constrained differential-algebraic system of report 004 in discrete
time: x(k+1) = Phi x(k) + Delta u(k), E u(k) + F x(k) = 0 (k = 0..N),
x(0) = x0, with boxes on u and x, and the norm
||(x, u)||^2 = sum_k x(k)' Q x(k) + u(k)' R u(k).

Phi = expm(A h) and Delta = integral_0^h expm(A s) ds B come from one
matrix exponential of the augmented matrix [[A, B], [0, 0]] h (the report's
series, summed exactly).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from ..errors import EngineError


@dataclass(frozen=True)
class DaeSystem:
    A: NDArray
    B: NDArray
    E: NDArray
    F: NDArray
    x0: NDArray
    horizon: float
    steps: int
    Q: NDArray
    R: NDArray
    u_lower: NDArray
    u_upper: NDArray
    x_lower: NDArray
    x_upper: NDArray
    integral: NDArray | None = None      # K1 as hyperplanes: rows c with c . vec(u) = integral_values
    integral_values: NDArray | None = None
    terminal: NDArray | None = None      # K2 also holds x_i(N) = value: rows (state index, value)
    open_loop: tuple[int, ...] | None = None   # inputs (from 1) held at 0 in the untrimmed open loop
    time_unit: tuple[str, float] = ("s", 1.0)  # how times are shown: name, seconds per unit

    @property
    def n(self) -> int:
        return self.A.shape[0]

    @property
    def m(self) -> int:
        return self.B.shape[1]

    def discrete(self) -> tuple[NDArray, NDArray]:
        """(Phi, Delta) for the step h = T/N."""
        h = self.horizon / self.steps
        n, m = self.n, self.m
        augmented = np.zeros((n + m, n + m))
        augmented[:n, :n], augmented[:n, n:] = self.A, self.B
        exp = expm(augmented * h)
        return exp[:n, :n], exp[:n, n:]

    def times(self) -> NDArray:
        return np.linspace(0.0, self.horizon, self.steps + 1)

    @property
    def boxed(self) -> bool:
        return bool(np.isfinite(np.concatenate([self.u_lower, self.u_upper, self.x_lower, self.x_upper])).any())


def _matrix(data: Mapping[str, Any], key: str, shape: tuple[int, int] | None = None) -> NDArray:
    if key not in data:
        raise EngineError(f"projection: the system needs {key}")
    try:
        value = np.array(data[key], dtype=float)
    except (TypeError, ValueError):
        raise EngineError(f"projection: {key} must be a matrix of numbers") from None
    value = np.atleast_2d(value)
    if shape is not None and value.shape != shape:
        raise EngineError(f"projection: {key} must be {shape[0]} x {shape[1]}, not {value.shape[0]} x {value.shape[1]}")
    if not np.all(np.isfinite(value)):
        raise EngineError(f"projection: {key} has a non-finite entry")
    return value


def _integrals(data: Mapping[str, Any], m: int, steps: int, horizon: float) -> tuple[NDArray | None, NDArray | None]:
    """integral_0^T t^power u_j(t) dt = value, exact for the held (piecewise constant) control."""
    items = data.get("integral_constraints") or []
    if not items:
        return None, None
    t = np.linspace(0.0, horizon, steps + 1)
    rows, values = [], []
    for item in items:
        j, power = int(item["input"]) - 1, int(item.get("power", 0))
        if not 0 <= j < m or power < 0:
            raise EngineError(f"projection: integral constraint on input {j + 1} with power {power} is not valid")
        row = np.zeros((steps + 1, m))
        row[:-1, j] = (t[1:] ** (power + 1) - t[:-1] ** (power + 1)) / (power + 1)
        rows.append(row.ravel())
        values.append(float(item["value"]))
    return np.array(rows), np.array(values)


def _terminal(data: Mapping[str, Any], n: int) -> NDArray | None:
    items = data.get("terminal") or []
    if not items:
        return None
    out = np.array([[int(i["state"]) - 1, float(i["value"])] for i in items])
    if np.any(out[:, 0] < 0) or np.any(out[:, 0] >= n):
        raise EngineError(f"projection: terminal constraints name states 1..{n}")
    return out


def _open_loop(data: Mapping[str, Any], m: int) -> tuple[int, ...] | None:
    spec = data.get("open_loop")
    if spec is None:
        return None
    zero = tuple(int(j) for j in spec.get("zero_inputs", []))
    if any(not 1 <= j <= m for j in zero):
        raise EngineError(f"projection: open_loop.zero_inputs name inputs 1..{m}")
    return zero


def _time_unit(data: Mapping[str, Any]) -> tuple[str, float]:
    raw = data.get("time_unit", ["s", 1.0])
    try:
        unit = (str(raw[0]), float(raw[1]))
    except (TypeError, ValueError, IndexError):
        raise EngineError("projection: time_unit is [name, seconds per unit], e.g. [\"h\", 3600]") from None
    if not unit[1] > 0:
        raise EngineError("projection: time_unit needs a positive number of seconds")
    return unit


def _weights(data: Mapping[str, Any], key: str, size: int, semidefinite: bool = False) -> NDArray:
    raw = data.get(key, [1.0] * size)
    value = np.array(raw, dtype=float)
    if value.ndim == 1:
        if value.shape != (size,):
            raise EngineError(f"projection: {key} needs {size} diagonal entries")
        value = np.diag(value)
    if value.shape != (size, size) or not np.allclose(value, value.T):
        raise EngineError(f"projection: {key} must be a symmetric {size} x {size} matrix")
    smallest = np.min(np.linalg.eigvalsh(value))
    if smallest < 0 or (smallest == 0 and not semidefinite):
        raise EngineError(f"projection: {key} must be positive {'semi' if semidefinite else ''}definite")
    return value


def _bounds(data: Mapping[str, Any], key: str, size: int, default: float) -> NDArray:
    raw = data.get(key)
    if raw is None:
        return np.full(size, default)
    values = [default if v is None else float(v) for v in raw]
    if len(values) != size:
        raise EngineError(f"projection: {key} needs {size} entries (null: unbounded)")
    return np.array(values)


def dae_system(data: Mapping[str, Any]) -> DaeSystem:
    """The system from plain data (an objective's ``data``), with every shape checked."""
    A = _matrix(data, "A")
    n = A.shape[0]
    if A.shape != (n, n):
        raise EngineError("projection: A must be square")
    B = _matrix(data, "B")
    if B.shape[0] != n:
        raise EngineError(f"projection: B needs {n} rows")
    m = B.shape[1]
    if "E" in data or "F" in data:
        E = _matrix(data, "E")
        p = E.shape[0]
        if E.shape[1] != m:
            raise EngineError(f"projection: E must have {m} columns")
        F = _matrix(data, "F", (p, n))
    else:   # no algebraic equation
        E, F, p = np.zeros((0, m)), np.zeros((0, n)), 0
    if p and np.linalg.matrix_rank(E) < p:
        raise EngineError("projection: E must have full row rank (each algebraic equation must involve u)")
    x0 = np.array(data.get("x0", [0.0] * n), dtype=float)
    steps, horizon = int(data.get("steps", 20)), float(data.get("horizon", 1.0))
    if x0.shape != (n,) or steps < 1 or not horizon > 0:
        raise EngineError(f"projection: x0 needs {n} entries, steps >= 1, horizon > 0")
    integral, values = _integrals(data, m, steps, horizon)
    system = DaeSystem(A, B, E, F, x0, horizon, steps, _weights(data, "Q", n, semidefinite=True),
                       _weights(data, "R", m), _bounds(data, "u_min", m, -np.inf), _bounds(data, "u_max", m, np.inf),
                       _bounds(data, "x_min", n, -np.inf), _bounds(data, "x_max", n, np.inf), integral, values,
                       _terminal(data, n), _open_loop(data, m), _time_unit(data))
    if system.integral is not None and system.boxed:
        raise EngineError("projection: K1 is either boxes or integral hyperplanes, not both (no closed-form "
                          "projection onto their intersection)")
    for name, lo, hi in (("u", system.u_lower, system.u_upper), ("x", system.x_lower, system.x_upper)):
        empty = np.flatnonzero(lo > hi)
        if empty.size:
            raise EngineError(f"projection: {name}{empty[0] + 1} has min > max: the box is empty")
    if system.boxed and (not _diagonal(system.Q) or not _diagonal(system.R)):
        raise EngineError("projection: clipping projects onto boxes only in a norm with diagonal Q and R")
    return system


def _diagonal(M: NDArray) -> bool:
    return bool(np.allclose(M, np.diag(np.diag(M))))

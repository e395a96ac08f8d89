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

from engine.errors import EngineError
from engine.projection.data import (
    MAX_INPUTS,
    MAX_POWER,
    MAX_STATES,
    MAX_STEPS,
    fail,
    integer,
    items,
    limits,
    matrix,
    number,
    obj,
    sizes,
    vector,
    weights,
)


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
    integral: NDArray | None = None  # K1 as hyperplanes: rows c with c . vec(u) = integral_values
    integral_values: NDArray | None = None
    terminal: NDArray | None = None  # K2 also holds x_i(N) = value: rows (state index, value)
    open_loop: tuple[int, ...] | None = None  # inputs (from 1) held at 0 in the untrimmed open loop
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
        with np.errstate(all="ignore"):
            scaled = augmented * h
            exp = expm(scaled) if np.all(np.isfinite(scaled)) else scaled
        if not np.all(np.isfinite(exp)):
            raise EngineError(f"projection: exp(A h) overflows (h = T/N = {h:.6g}): a shorter horizon or more steps")
        return exp[:n, :n], exp[:n, n:]

    def times(self) -> NDArray:
        return np.linspace(0.0, self.horizon, self.steps + 1)

    @property
    def boxed(self) -> bool:
        return bool(np.isfinite(np.concatenate([self.u_lower, self.u_upper, self.x_lower, self.x_upper])).any())


def _integrals(data: Mapping[str, Any], m: int, steps: int, horizon: float) -> tuple[NDArray | None, NDArray | None]:
    """integral_0^T t^power u_j(t) dt = value, exact for the held (piecewise constant) control."""
    entries = items(data.get("integral_constraints") or [], "integral_constraints")
    if not entries:
        return None, None
    t = np.linspace(0.0, horizon, steps + 1)
    rows, values = [], []
    for k, entry in enumerate(entries):
        key = f"integral_constraints[{k}]"
        entry = obj(entry, key)
        j = integer(entry.get("input"), f"{key}.input", 1, m) - 1
        power = integer(entry.get("power", 0), f"{key}.power", 0, MAX_POWER)
        row = np.zeros((steps + 1, m))
        with np.errstate(all="ignore"):
            row[:-1, j] = (t[1:] ** (power + 1) - t[:-1] ** (power + 1)) / (power + 1)
        if not np.all(np.isfinite(row)):
            raise fail(key, f"t^{power + 1} overflows over the horizon {horizon:g}")
        rows.append(row.ravel())
        values.append(number(entry.get("value"), f"{key}.value"))
    return np.array(rows), np.array(values)


def _terminal(data: Mapping[str, Any], n: int) -> NDArray | None:
    entries = items(data.get("terminal") or [], "terminal")
    if not entries:
        return None
    out = []
    for k, entry in enumerate(entries):
        entry = obj(entry, f"terminal[{k}]")
        out.append(
            [
                integer(entry.get("state"), f"terminal[{k}].state", 1, n) - 1,
                number(entry.get("value"), f"terminal[{k}].value"),
            ]
        )
    return np.array(out, dtype=float)


def _open_loop(data: Mapping[str, Any], m: int) -> tuple[int, ...] | None:
    spec = data.get("open_loop")
    if spec is None:
        return None
    zero = items(obj(spec, "open_loop").get("zero_inputs", []), "open_loop.zero_inputs", m)
    return tuple(integer(j, f"open_loop.zero_inputs[{i}]", 1, m) for i, j in enumerate(zero))


def _time_unit(data: Mapping[str, Any]) -> tuple[str, float]:
    raw = data.get("time_unit", ["s", 1.0])
    if not (isinstance(raw, list) and len(raw) == 2 and isinstance(raw[0], str)):
        raise EngineError('projection: time_unit is [name, seconds per unit], e.g. ["h", 3600]')
    return raw[0][:20], number(raw[1], "time_unit[1]", positive=True)


def _algebraic(data: Mapping[str, Any], n: int, m: int) -> tuple[NDArray, NDArray]:
    """E and F of E u + F x = 0 (none: no algebraic equation)."""
    if "E" not in data and "F" not in data:
        return np.zeros((0, m)), np.zeros((0, n))
    if "E" not in data or "F" not in data:
        raise EngineError("projection: give both E and F (E u + F x = 0), or neither")
    E = matrix(data["E"], "E", columns=m, most=MAX_INPUTS)
    F = matrix(data["F"], "F", E.shape[0], n, most=MAX_INPUTS)
    if np.linalg.matrix_rank(E) < E.shape[0]:
        raise EngineError("projection: E must have full row rank (each algebraic equation must involve u)")
    return E, F


def dae_system(data: Mapping[str, Any]) -> DaeSystem:
    """The system from plain data (an objective's ``data``), with every type, shape and size checked."""
    data = obj(data, "(top)")
    for key in ("A", "B"):
        if key not in data:
            raise EngineError(f"projection: the system needs {key}")
    A = matrix(data["A"], "A")
    n = A.shape[0]
    if A.shape != (n, n):
        raise EngineError("projection: A must be square")
    B = matrix(data["B"], "B", n, most=MAX_STATES)
    m = B.shape[1]
    if m > MAX_INPUTS:
        raise fail("B", f"at most {MAX_INPUTS} inputs, not {m}")
    E, F = _algebraic(data, n, m)
    x0 = vector(data.get("x0", [0.0] * n), "x0", n)
    steps = integer(data.get("steps", 20), "steps", 1, MAX_STEPS)
    horizon = number(data.get("horizon", 1.0), "horizon", positive=True)
    sizes(n, m, steps)
    integral, values = _integrals(data, m, steps, horizon)
    system = DaeSystem(
        A,
        B,
        E,
        F,
        x0,
        horizon,
        steps,
        weights(data, "Q", n, semidefinite=True),
        weights(data, "R", m),
        limits(data.get("u_min"), "u_min", m, -np.inf),
        limits(data.get("u_max"), "u_max", m, np.inf),
        limits(data.get("x_min"), "x_min", n, -np.inf),
        limits(data.get("x_max"), "x_max", n, np.inf),
        integral,
        values,
        _terminal(data, n),
        _open_loop(data, m),
        _time_unit(data),
    )
    if system.integral is not None and system.boxed:
        raise EngineError(
            "projection: K1 is either boxes or integral hyperplanes, not both (no closed-form "
            "projection onto their intersection)"
        )
    for name, lo, hi in (("u", system.u_lower, system.u_upper), ("x", system.x_lower, system.x_upper)):
        empty = np.flatnonzero(lo > hi)
        if empty.size:
            raise EngineError(f"projection: {name}{empty[0] + 1} has min > max: the box is empty")
    if system.boxed and (not _diagonal(system.Q) or not _diagonal(system.R)):
        raise EngineError("projection: clipping projects onto boxes only in a norm with diagonal Q and R")
    return system


def _diagonal(M: NDArray) -> bool:
    return bool(np.allclose(M, np.diag(np.diag(M))))

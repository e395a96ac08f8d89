"""Typed reading of a `dae` objective's free-form data: every value checked for
its type, its size and finiteness, every failure an `EngineError` naming the
key (``projection: data.A[2][1]: ...``), never a Python traceback."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError, shown_json

MAX_STATES = 200  # n
MAX_INPUTS = 200  # m (and algebraic equations)
MAX_STEPS = 100_000  # N
MAX_WORK = 2e9  # N (2n + m)^3: the banded KKT factorization's flops, a few seconds at most
MAX_POWER = 20  # of t in an integral constraint
MAX_ITEMS = 1000  # integral and terminal constraints


def fail(key: str, message: str) -> EngineError:
    """The error for a bad value at ``key``."""
    return EngineError(f"projection: data.{key}: {message}")


def number(value: Any, key: str, *, positive: bool = False) -> float:
    """A finite number (``positive``: > 0)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise fail(key, f"expected a number, got {shown_json(value)}")
    try:
        x = float(value)
    except OverflowError:
        raise fail(key, "the number is too large") from None
    if not math.isfinite(x):
        raise fail(key, f"expected a finite number, got {x!r}")
    if positive and not x > 0:
        raise fail(key, f"must be > 0, not {x!r}")
    return x


def integer(value: Any, key: str, low: int, high: int) -> int:
    """An integer in low..high (an integral float such as 20.0 too)."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise fail(key, f"expected an integer in {low}..{high}, got {shown_json(value)}")
    return value


def items(value: Any, key: str, most: int = MAX_ITEMS) -> list:
    """A list of at most ``most`` items."""
    if not isinstance(value, list):
        raise fail(key, f"expected a list, got {shown_json(value)}")
    if len(value) > most:
        raise fail(key, f"at most {most} items, not {len(value)}")
    return value


def obj(value: Any, key: str) -> Mapping[str, Any]:
    """An object (a JSON dict)."""
    if not isinstance(value, Mapping):
        raise fail(key, f"expected an object, got {shown_json(value)}")
    return value


def vector(value: Any, key: str, size: int) -> NDArray:
    """``size`` finite numbers."""
    values = items(value, key, size)
    if len(values) != size:
        raise fail(key, f"expected {size} numbers, got {len(values)}")
    return np.array([number(v, f"{key}[{i}]") for i, v in enumerate(values)], dtype=float)


def matrix(
    value: Any, key: str, rows: int | None = None, columns: int | None = None, most: int = MAX_STATES
) -> NDArray:
    """A list of equally long lists of finite numbers (a list of numbers is one row)."""
    data = items(value, key, most)
    if data and not isinstance(data[0], list):
        data = [data]
    if not data:
        raise fail(key, "expected a matrix, got an empty list")
    width = columns if columns is not None else len(items(data[0], f"{key}[0]", most))
    out = np.array([vector(row, f"{key}[{i}]", width) for i, row in enumerate(data)], dtype=float)
    if rows is not None and out.shape[0] != rows:
        raise fail(key, f"expected {rows} rows, got {out.shape[0]}")
    return out


def limits(value: Any, key: str, size: int, default: float) -> NDArray:
    """Bounds: ``size`` numbers or nulls (null: unbounded; an infinity of the unbounded sign too)."""
    if value is None:
        return np.full(size, default)
    values = items(value, key, size)
    if len(values) != size:
        raise fail(key, f"needs {size} entries (null: unbounded), got {len(values)}")
    out = []
    for i, v in enumerate(values):
        if v is None or (isinstance(v, float) and v == default):
            out.append(default)
        else:
            out.append(number(v, f"{key}[{i}]"))
    return np.array(out, dtype=float)


def weights(data: Mapping[str, Any], key: str, size: int, semidefinite: bool = False) -> NDArray:
    """A symmetric positive (semi)definite weight, or its diagonal."""
    raw = data.get(key, [1.0] * size)
    first = items(raw, key, size)[:1]
    value = matrix(raw, key, size, size) if first and isinstance(first[0], list) else np.diag(vector(raw, key, size))
    scale = float(np.abs(value).max(initial=0.0))
    if not np.allclose(value, value.T, rtol=1e-12, atol=1e-12 * scale):
        raise fail(key, f"must be a symmetric {size} x {size} matrix")
    with np.errstate(all="ignore"):
        try:
            smallest = float(np.min(np.linalg.eigvalsh(value / scale))) if scale > 0 else 0.0
        except np.linalg.LinAlgError:
            raise fail(key, "its eigenvalues cannot be computed") from None
    if smallest < -1e-14 or (smallest <= 0 and not semidefinite):
        raise fail(key, f"must be positive {'semi' if semidefinite else ''}definite")
    return value


def sizes(n: int, m: int, steps: int) -> None:
    """Refuse a system whose projection would take more than seconds."""
    work = (steps + 1) * float(2 * n + m) ** 3
    if work > MAX_WORK:
        raise EngineError(
            f"projection: {steps} steps of {n} states and {m} inputs are beyond the limit "
            f"(N (2n + m)^3 = {work:.3g} > {MAX_WORK:.0e}): fewer steps or a smaller system"
        )

"""Axis ticks and the points a text canvas can show: round ticks, decade ticks
of a log-frequency axis drawn as log10(omega), and finite series thinned to
what a canvas resolves."""

from __future__ import annotations

import math

import numpy as np

MAX_POINTS = 600  # a text canvas resolves fewer; more only slows the drawing down


def nice_ticks(low: float, high: float, count: int = 5) -> tuple[list[float], list[str]]:
    """Round ticks (1, 2 or 5 times a power of ten apart) inside [low, high]."""
    power = 10.0 ** math.floor(math.log10((high - low) / max(count - 1, 1)))
    candidates = [m * power * scale for scale in (0.1, 1.0, 10.0) for m in (1, 2, 5)]
    step = next(c for c in candidates if math.floor(high / c) - math.ceil(low / c) + 1 <= count + 1)
    first = math.ceil(low / step) * step
    ticks = [round(first / step + k) * step for k in range(int((high - first) / step + 1e-9) + 1)]
    digits = max(0, -math.floor(math.log10(step) + 1e-12))
    return ticks, [f"{t:.{digits}f}" if abs(t) < 1e6 and digits <= 6 else f"{t:.3g}" for t in ticks]


def finite_points(x: np.ndarray, y: np.ndarray) -> tuple[list[float], list[float]]:
    """The finite points of a series, thinned to about MAX_POINTS (the last one kept)."""
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    if x.size > MAX_POINTS:
        step = int(np.ceil(x.size / MAX_POINTS))
        x, y = np.concatenate([x[::step], x[-1:]]), np.concatenate([y[::step], y[-1:]])
    return x.tolist(), y.tolist()


def decade_ticks(log_w: np.ndarray) -> tuple[list[float], list[str]]:
    """Ticks at every decade spanned by log10(omega) values, labelled with omega."""
    lo, hi = math.floor(np.nanmin(log_w)), math.ceil(np.nanmax(log_w))
    ticks = list(range(lo, hi + 1))
    return [float(t) for t in ticks], [f"{10.0**t:g}" for t in ticks]

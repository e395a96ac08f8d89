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


PREFIXES = {-9: "n", -6: "µ", -3: "m", 0: "", 3: "k", 6: "M", 9: "G"}  # beyond: 1e-12, 4e13


def engineering(value: float) -> str:
    """A tick value in engineering form: 1k, 10m, 2.5M (3 significant digits at most)."""
    if value == 0 or not math.isfinite(value):
        return f"{value:g}"
    power = 3 * math.floor(math.log10(abs(value)) / 3)
    if power not in PREFIXES:
        return f"{value:.3g}"
    return f"{value / 10.0**power:.3g}{PREFIXES[power]}"


def spaced(ticks: list[float], labels: list[str], span: tuple[float, float], cells: int, axis: str):
    """The ticks whose labels keep at least one blank cell between them on an axis of
    ``cells`` rows (y) or columns (x) over ``span``: labels in engineering form where that
    is shorter, then every second (third, ...) tick, the outer ones first kept."""
    low, high = span
    if not ticks or cells <= 0 or not high > low:
        return ticks, labels
    where = [(t - low) / (high - low) * (cells - 1) for t in ticks]
    short = [_shorter(label) for label in labels]
    if _apart(where, labels, axis):
        return ticks, labels
    for step in range(1, len(ticks) + 1):
        kept = list(range(0, len(ticks), step))
        if _apart([where[k] for k in kept], [short[k] for k in kept], axis):
            return [ticks[k] for k in kept], [short[k] for k in kept]
    return ticks[:1], short[:1]


def _shorter(label: str) -> str:
    """A number's label in engineering form where that is shorter ("0.001" -> "1m")."""
    try:
        short = engineering(float(label))
    except ValueError:
        return label
    return short if len(short) < len(label) else label


def _apart(where: list[float], labels: list[str], axis: str) -> bool:
    """Are labels at these cell positions one blank cell (row or column) apart?"""
    cells = [round(w) for w in where]
    for (a, label_a), (b, label_b) in zip(zip(cells, labels), zip(cells[1:], labels[1:])):
        needed = 2 if axis == "y" else (len(label_a.strip()) + len(label_b.strip())) / 2 + 1
        if abs(b - a) < needed:
            return False
    return True

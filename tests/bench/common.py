"""Timing, targets and fits shared by the benchmarks.

Every comparison is interleaved (A B A B ...): the ratio is taken per pair
and the figure is the median of those ratios, so a change in the shared
machine's speed during a run affects both sides alike.  Every figure carries
its target and ``met``; ratio targets are ``enforced`` (``make bench`` fails
when one is missed), absolute times are reported only (this machine's
cores are shared)."""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable, Sequence

import numpy as np

Timed = Callable[[int], object]
KINDS = {"max_s": False, "min_ratio": True, "max_ratio": True}  # target kind: enforced?


def samples(funs: Sequence[Timed], repeat: int) -> list[list[float]]:
    """Wall times of each fun(i), the functions called in turn at every
    i = 1..repeat (after one warm-up call each)."""
    for fun in funs:
        fun(0)
    times: list[list[float]] = [[] for _ in funs]
    for i in range(1, repeat + 1):
        for fun, row in zip(funs, times):
            start = time.perf_counter()
            fun(i)
            row.append(time.perf_counter() - start)
    return times


def median_time(fun: Timed, repeat: int) -> float:
    """Median wall time of fun(i) over i = 1..repeat, after one warm-up call."""
    return statistics.median(samples([fun], repeat)[0])


def judged(value: float | None, target: float, kind: str) -> dict:
    """The target of a figure and whether ``value`` meets it (``max_s``: at
    most, reported; ``min_ratio``/``max_ratio``: at least/at most, enforced)."""
    if value is None or not math.isfinite(value):
        met = False
    else:
        met = value >= target if kind == "min_ratio" else value <= target
    return {"target": target, "target_kind": kind, "met": bool(met), "enforced": KINDS[kind]}


def timed(value: float, target: float | None = None, **extra) -> dict:
    """An absolute-time figure: its median (s) and, when given, its target."""
    return {"median_s": value, **(judged(value, target, "max_s") if target is not None else {}), **extra}


def compared(ours: Timed, theirs: Timed, repeat: int, target: float | None = None, **extra) -> dict:
    """Ours against theirs interleaved: both medians, the median of the
    per-pair ratios theirs/ours (> 1: ours is faster) and its target."""
    a, b = samples([ours, theirs], repeat)
    ratio = statistics.median([t / o for o, t in zip(a, b)])
    out = {
        "ours_median_s": statistics.median(a),
        "theirs_median_s": statistics.median(b),
        "ratio": ratio,
        "pairs": repeat,
        **extra,
    }
    return out | (judged(ratio, target, "min_ratio") if target is not None else {})


def exponent(sizes: Sequence[float], times: Sequence[float]) -> float:
    """Least-squares slope of log(time) against log(size): time ~ size**exponent."""
    return float(np.polyfit(np.log(np.asarray(sizes, dtype=float)), np.log(np.asarray(times, dtype=float)), 1)[0])


def scaling(name: str, sizes: Sequence[float], times: Sequence[float]) -> dict:
    """A scaling study: the sizes, the median times and the fitted exponent."""
    return {"variable": name, "sizes": list(sizes), "median_s": list(times), "exponent": exponent(sizes, times)}


def missed(results: object, path: str = "") -> list[str]:
    """Paths of every figure whose enforced target was missed."""
    if isinstance(results, dict):
        here = [path] if results.get("enforced") and results.get("met") is False else []
        return here + [p for k, v in results.items() for p in missed(v, f"{path}.{k}" if path else str(k))]
    if isinstance(results, list):
        return [p for k, v in enumerate(results) for p in missed(v, f"{path}[{k}]")]
    return []


def targets(results: object, path: str = "") -> list[tuple[str, dict]]:
    """Every figure with a target, with its path (for the printed summary)."""
    if isinstance(results, dict):
        here = [(path, results)] if "met" in results else []
        return here + [t for k, v in results.items() for t in targets(v, f"{path}.{k}" if path else str(k))]
    if isinstance(results, list):
        return [t for k, v in enumerate(results) for t in targets(v, f"{path}[{k}]")]
    return []


def perturbed(params: dict, i: int) -> dict:
    """New parameter values each call (1e-12 relative), so no cache can answer."""
    return {k: v * (1.0 + 1e-12 * i) for k, v in params.items()}

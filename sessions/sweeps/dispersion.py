"""What a tolerance study shows per measure and flight condition: the values'
distribution (a histogram), their percentiles, the fraction of samples that miss
the requirement with its 95 % Clopper-Pearson interval, and the worst sample with
its drawn parameter values; and which row's worst sample is the study's worst.

Percentiles are numpy's (linear interpolation between order statistics) over the
samples where the measure has a value (a NaN, an undefined measure, is counted as
undefined and as unmet); between an infinity and its neighbour the percentile is the
infinity (numpy's arithmetic gives NaN there).  The histogram is of the finite
values; infinite ones are counted beside it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sessions.errors import SessionError

PERCENTILES = (1, 5, 50, 95, 99)
PERCENTILE_KEYS = tuple(f"p{p}" for p in PERCENTILES)  # a row's percentiles by these keys
CONFIDENCE = 0.95
HISTOGRAM_BINS = 20  # at most; sqrt(samples) below 400 samples


def percentiles(values: np.ndarray) -> list[float]:
    """The `PERCENTILES` of ``values`` (not NaN, at least one), infinities kept."""
    ordered = np.sort(np.asarray(values, dtype=float))
    with np.errstate(invalid="ignore"):
        linear = np.percentile(ordered, PERCENTILES)
    position = np.array(PERCENTILES) / 100.0 * (ordered.size - 1)
    low, high = ordered[np.floor(position).astype(int)], ordered[np.ceil(position).astype(int)]
    infinite = np.where(np.isinf(low), low, high)  # NaN only where an infinity is one of the two
    return [float(v) for v in np.where(np.isnan(linear), infinite, linear)]


def clopper_pearson(unmet: int, samples: int, confidence: float = CONFIDENCE) -> tuple[float, float]:
    """The exact (Clopper-Pearson) interval of a binomial fraction ``unmet / samples``:
    the beta distribution's quantiles (scipy.special's inverse of the regularized
    incomplete beta function, as scipy.stats.beta.ppf computes them, without importing
    scipy.stats: 0.7 s), 0 below no unmet sample, 1 above all."""
    from scipy.special import betaincinv

    if samples < 1 or not 0 <= unmet <= samples:
        raise ValueError(f"{unmet} unmet of {samples} samples")
    tail = (1.0 - confidence) / 2.0
    low = 0.0 if unmet == 0 else float(betaincinv(unmet, samples - unmet + 1, tail))
    high = 1.0 if unmet == samples else float(betaincinv(unmet + 1, samples - unmet, 1.0 - tail))
    return low, high


def histogram(values: np.ndarray) -> dict:
    """Bin edges and counts of the finite ``values``; ``below`` and ``above``: how many
    are minus and plus infinity."""
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    below, above = int(np.sum(values == -math.inf)), int(np.sum(values == math.inf))
    if not finite.size:
        return {"edges": [], "counts": [], "below": below, "above": above}
    counts, edges = np.histogram(finite, bins=min(HISTOGRAM_BINS, math.ceil(math.sqrt(finite.size))))
    return {"edges": edges.tolist(), "counts": counts.tolist(), "below": below, "above": above}


def distribution(values: np.ndarray, unmet: int) -> dict:
    """A row's distribution fields from its samples' values (NaN: undefined) and how many are unmet."""
    values = np.asarray(values, dtype=float)
    defined = values[~np.isnan(values)]
    low, high = clopper_pearson(unmet, values.size)
    return {
        "percentiles": dict(zip(PERCENTILE_KEYS, percentiles(defined))) if defined.size else {},
        "undefined": int(values.size - defined.size),
        "unmet_fraction": unmet / values.size,
        "unmet_interval": [low, high],
        "histogram": histogram(defined),
    }


def with_distributions(rows: Sequence[dict], runs: Sequence[dict]) -> list[dict]:
    """The worst-case rows (`sessions.sweeps.results.worst_case`, of these ``runs``) with
    each one's distribution and its worst sample's drawn values (``worst_parameters``)."""
    values: dict[tuple, list[float]] = {}
    for run in runs:
        for m in run["measures"]:
            values.setdefault((m["name"], m["kind"], m["condition"]), []).append(float(m["value"]))
    start = {run["index"]: run["start"] for run in runs}
    return [
        {
            **row,
            **distribution(np.array(values[(row["name"], row["kind"], row["condition"])]), row["unmet_samples"]),
            "worst_parameters": start[row["worst_sample"]],
        }
        for row in rows
    ]


def shortfall(row: dict) -> float:
    """How far a row's worst value misses its desired value, relative to it (to 1 when it
    is 0): negative when every sample meets it, NaN (undefined everywhere) the largest,
    no desired value the smallest."""
    desired, worst = row.get("desired"), float(row["worst"])
    if desired is None:
        return -math.inf
    if math.isnan(worst):
        return math.inf
    desired = float(desired)
    missed = desired - worst if row.get("at_least", True) else worst - desired
    if math.isnan(missed):  # an infinite worst value at an infinite desired one: met
        return -math.inf
    return missed / (abs(desired) or 1.0) if math.isfinite(missed) else math.copysign(math.inf, missed)


def worst_row(rows: Sequence[dict], which: str | None = None) -> dict:
    """The row whose worst sample is the study's worst (the largest `shortfall`), among
    those named by ``which`` (MEASURE or MEASURE@CONDITION; None: every row)."""
    if not rows:
        raise SessionError("no sample of the tolerance study finished")
    name, _, condition = (which or "").partition("@")
    chosen = [
        r for r in rows if which is None or (r["name"] == name and (not condition or r["condition"] == condition))
    ]
    if not chosen:
        known = ", ".join(sorted({f"{r['name']}@{r['condition']}" for r in rows})) or "none"
        raise SessionError(f"no measure row {which!r} in the tolerance study (rows: {known})")
    return max(chosen, key=shortfall)

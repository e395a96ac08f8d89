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
from array import array
from collections import Counter
from collections.abc import Sequence

import numpy as np

from sessions.errors import SessionError
from sessions.sweeps.records import Records

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


CANCELLED = "cancelled"  # the reason of a run that did not finish (a sweep stopped before it)
EVERY_RUN_KEPT = 10_000  # a study of at most this many samples keeps every sample's run
FAILED_RUNS_KEPT = 20  # ... a larger one the worst samples' runs and the first failed ones (their reasons)


class Tally:
    """A tolerance study's outputs gathered run by run (`add`, in job order): per measure row
    (name, kind, condition) its values as a float array, how many are unmet, its worst value
    and sample; every failed run's index, and how many failed for each reason (``excluded``).  What it keeps of the runs themselves: every run,
    or, when ``every_run`` is False (a study of more than `EVERY_RUN_KEPT` samples), only
    each row's worst sample's run and the first `FAILED_RUNS_KEPT` failed runs, so that its
    memory does not grow by a run (some 2 KB) per sample."""

    def __init__(self, every_run: bool = True) -> None:
        self.every_run = every_run
        self.count = 0  # runs added
        self.cancelled = 0  # ... of which cancelled
        self.failed: list[int] = []  # every failed run's index, in the order added
        self.excluded: Counter[str] = Counter()  # reason -> how many samples it left out of the statistics
        self._rows: dict[tuple, _Row] = {}  # in the order first seen
        self._runs: dict[int, dict] = {}  # index -> run: the runs kept
        self._every: list[dict] = []  # every run in the order added, when every run is kept
        self._failed_kept: set[int] = set()
        self.counted = array("q")  # the samples whose rows' values were added, in that order

    @classmethod
    def of_study(cls, samples: int) -> Tally:
        """Where a study of ``samples`` runs is gathered as they are made: every run kept up to
        `EVERY_RUN_KEPT` samples, above that only what the study's outputs need."""
        return cls(every_run=samples <= EVERY_RUN_KEPT)

    @classmethod
    def of(cls, runs: Sequence[dict]) -> Tally:
        """The tally of a whole study's runs (`of_study`)."""
        tally = cls.of_study(len(runs))
        for run in runs:
            tally.add(run)
        return tally

    def add(self, run: dict) -> None:
        """One run more (its measures counted when it did not fail)."""
        self.count += 1
        if self.every_run:
            self._every.append(run)
            self._runs[run["index"]] = run
        if run.get("status") == "failed":
            self.failed.append(run["index"])
            self.excluded[run["reason"]] += 1
            self.cancelled += run["reason"] == CANCELLED
            if not self.every_run and len(self._failed_kept) < FAILED_RUNS_KEPT:
                self._failed_kept.add(run["index"])
                self._runs[run["index"]] = run
            return
        self.counted.append(run["index"])
        rows = self._rows
        for m in run["measures"]:
            key = (m["name"], m["kind"], m["condition"])
            row = rows.get(key)
            if row is None:
                row = rows[key] = _Row(m)
            value = m["value"]
            if not isinstance(value, (int, float)):
                value = float(value)  # "inf", "-inf", "nan" as the session's JSON writes them
            row.values.append(value)
            if not m["satisfied"]:
                row.unmet += 1
            worst = row.worst
            if worst != worst or (value < worst if m["at_least"] else value > worst):  # NaN: any value replaces it
                before, row.worst, row.worst_sample = row.worst_sample, value, run["index"]
                if not self.every_run:
                    self._runs[run["index"]] = run
                    self._release(before)

    def add_records(self, records: Records) -> None:
        """A stretch of batched samples' runs held as arrays, as `add` would take them one by one
        (none failed): each row's values appended whole, its worst sample found by reductions,
        a run made only when it is kept (every run, or a row's worst sample's)."""
        indices, made = records.indices, {}

        def run(j: int) -> dict:
            if j not in made:
                made[j] = records.run(j)
            return made[j]

        self.count += len(indices)
        self.counted.extend(indices)
        if self.every_run:
            for j in range(len(indices)):
                self._every.append(run(j))
                self._runs[indices[j]] = made[j]
        replaced = []
        for i, head in enumerate(records.heads):
            key = (head.name, head.kind, head.condition)
            row = self._rows.get(key)
            if row is None:
                row = self._rows[key] = _Row(head.as_dict())
            values = records.values[:, i]
            row.values.frombytes(np.ascontiguousarray(values, dtype=float).tobytes())
            row.unmet += int(np.count_nonzero(~records.points.met[:, i]))
            j = _worst_of(row.worst, values, head.at_least)
            if j is not None:
                replaced.append(row.worst_sample)
                row.worst, row.worst_sample = float(values[j]), indices[j]
                if not self.every_run:
                    self._runs[indices[j]] = run(j)
        if not self.every_run:
            for before in replaced:
                self._release(before)

    def sample_values(self) -> dict[str, np.ndarray]:
        """Every counted sample's row values as arrays: "index" (the samples, in the order
        counted) and one array per row, "NAME@CONDITION", aligned with it."""
        out = {"index": np.frombuffer(self.counted, dtype=np.int64).copy()}
        for (name, _, condition), row in self._rows.items():
            out[f"{name}@{condition}"] = np.frombuffer(row.values, dtype=float).copy()
        return out

    def _release(self, index: int | None) -> None:
        """Drop a run no row's worst sample is any more (when only those are kept)."""
        if index is None or index in self._failed_kept or any(r.worst_sample == index for r in self._rows.values()):
            return
        self._runs.pop(index, None)

    @property
    def finished(self) -> int:
        """How many runs ran to their end (not cancelled)."""
        return self.count - self.cancelled

    @property
    def thinned(self) -> bool:
        """Did it keep fewer runs than it was given?"""
        return not self.every_run and len(self._runs) < self.count

    def runs(self) -> list[dict]:
        """The runs kept: every run in the order added, or the worst samples' and the first
        failed ones by index."""
        return list(self._every) if self.every_run else sorted(self._runs.values(), key=lambda run: run["index"])

    def worst_case(self) -> list[dict]:
        """Per measure row: the worst value over the samples, the sample it is of, and how
        many samples miss the desired value (`sessions.sweeps.results.worst_case`)."""
        return [row.worst_row() for row in self._rows.values()]

    def rows(self) -> list[dict]:
        """The worst-case rows with each one's distribution and its worst sample's drawn
        values (``worst_parameters``)."""
        return [
            {
                **row.worst_row(),
                **distribution(np.frombuffer(row.values, dtype=float), row.unmet),
                "worst_parameters": self._runs[row.worst_sample]["start"],
            }
            for row in self._rows.values()
        ]

    @property
    def note(self) -> str:
        """What a study that kept only some runs says of it ("" when it kept every run)."""
        if not self.thinned:
            return ""
        return (
            f"the runs of {len(self._runs)} of {self.count} samples kept (each row's worst sample"
            + (", the first failed" if self._failed_kept else "")
            + f"): a study of more than {EVERY_RUN_KEPT} samples keeps its distributions, not every run"
        )


def _worst_of(worst: float, values: np.ndarray, at_least: bool) -> int | None:
    """The position in ``values`` of the sample that is a row's worst after them, taken one by
    one after the worst ``worst`` (`Tally.add`'s rule: a NaN worst is replaced by any value, a
    value by a strictly worse one, the first of equals kept); None when it stays."""
    start, best = 0, None
    if worst != worst:
        defined = np.flatnonzero(~np.isnan(values))
        if defined.size == 0:
            return values.size - 1 if values.size else None
        best = start = int(defined[0])
        worst, start = float(values[best]), best + 1
    rest = values[start:]
    if rest.size and not np.isnan(rest).all():
        extreme = np.nanmin(rest) if at_least else np.nanmax(rest)
        if extreme < worst if at_least else extreme > worst:
            best = start + int(np.flatnonzero(rest == extreme)[0])
    return best


class _Row:
    """One measure row of a `Tally`: its first run's fields and what the samples gave."""

    __slots__ = ("head", "values", "unmet", "worst", "worst_sample")

    def __init__(self, first: dict) -> None:
        self.head = {k: first[k] for k in ("name", "kind", "condition", "desired", "at_least")}
        self.values = array("d")  # every sample's value, 8 bytes each
        self.unmet = 0
        self.worst = math.nan
        self.worst_sample: int | None = None

    def worst_row(self) -> dict:
        return {
            **self.head,
            "worst": self.worst,
            "worst_sample": self.worst_sample,
            "unmet_samples": self.unmet,
            "samples": len(self.values),
        }


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
    return max(rows_named(rows, which), key=shortfall)


def rows_named(rows: Sequence[dict], which: str | None) -> list[dict]:
    """The rows (each with its ``name`` and ``condition``) that ``which`` names (MEASURE or
    MEASURE@CONDITION; None: every row); a `SessionError` listing them when none is.  A row's
    name may hold an '@' itself (a row at another loop break, PM1@u_att): ``which`` is matched
    whole against the name and against NAME@CONDITION, never split."""
    chosen = [r for r in rows if which is None or which in (r["name"], f"{r['name']}@{r['condition']}")]
    if not chosen:
        known = ", ".join(sorted({f"{r['name']}@{r['condition']}" for r in rows})) or "none"
        raise SessionError(f"no measure row {which!r} in the tolerance study (rows: {known})")
    return chosen


def run_count(summary: dict) -> str:
    """'2000 runs', or a large tolerance study's '100000 runs (42 kept)': its samples, not the runs
    it keeps (`Tally`: its worst samples' and the first failed ones)."""
    settings = summary.get("settings", {})
    kept = settings.get("runs_kept")
    total = settings.get("samples", len(summary["runs"])) if kept is not None else len(summary["runs"])
    return f"{total} runs" + (f" ({kept} kept)" if kept is not None else "")

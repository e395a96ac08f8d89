"""The runs of a stretch of batched tolerance samples held as arrays (`Records`): every
sample's row values, frequencies and verdicts (`engine.slp.points`), each sample's run
made only when it is kept (`run`), as `sessions.sweeps.jobs.run_job` makes it (its rows
`engine.slp.algorithm.Slp.row_fields`'s, written as `StepRecord.to_json` writes them).
A study's `Tally` takes such a stretch whole (`Tally.add_records`): its rows' values
appended as arrays, its worst samples found by array reductions, no Python object made
per sample and row but for the runs it keeps."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple, overload

import numpy as np
from numpy.typing import NDArray

from engine.design.measure_kinds import absent_reason

if TYPE_CHECKING:  # the command line imports this module (a study's tally) and loads no algorithm
    from engine.slp.measures import Spec
    from engine.slp.points import Points


class RowHead(NamedTuple):
    """What every sample's run says of a measure row but its value: its name, kind,
    condition's name, desired value (the row's requirement) and sense."""

    name: str
    kind: str
    condition: str
    desired: float | None
    at_least: bool

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "kind": self.kind,
            "condition": self.condition,
            "desired": self.desired,
            "at_least": self.at_least,
        }


def row_heads(specs: tuple[Spec, ...], conditions: list[str]) -> list[RowHead]:
    """The heads of slp's rows (`Slp.row_fields`' constant fields)."""
    return [RowHead(s.name, s.kind, conditions[s.condition], s.required, s.at_least) for s in specs]


Head = tuple[int, str, dict]  # a sample's index, label and drawn values (a job's ``start``)


@dataclass(frozen=True)
class Heads(Sequence[Head]):
    """Samples' heads made when read from arrays: their ``indices`` and each drawn parameter's
    values (``columns``: (samples,), or (samples, conditions)), labelled "sample INDEX"; no
    Python object per sample until one is read (a run kept)."""

    indices: NDArray[np.int64]
    columns: Mapping[str, NDArray[np.float64]]

    def __len__(self) -> int:
        return self.indices.size

    @overload
    def __getitem__(self, key: int) -> Head: ...
    @overload
    def __getitem__(self, key: slice) -> Heads: ...
    def __getitem__(self, key: int | slice) -> Head | Heads:
        if isinstance(key, slice):
            return Heads(self.indices[key], {name: column[key] for name, column in self.columns.items()})
        index = int(self.indices[key])
        return index, f"sample {index}", {name: column[key].tolist() for name, column in self.columns.items()}


@dataclass(frozen=True)
class Records:
    """Consecutive batched samples (``samples``: index, label and drawn values each) with their
    free vectors ``xs``, row values and frequencies (samples, rows) and verdicts ``points``;
    ``named``: the study's named start values; ``seconds``: each sample's share of the batch."""

    samples: Sequence[Head]
    heads: list[RowHead]
    values: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    points: Points
    named: dict
    seconds: float
    worker: str = "local"  # where they were computed: a cluster worker's address, or this process

    @property
    def indices(self) -> list[int]:
        if isinstance(self.samples, Heads):
            return self.samples.indices.tolist()
        return [index for index, _, _ in self.samples]

    def runs(self) -> list[dict]:
        return [self.run(j) for j in range(len(self.samples))]

    def run(self, j: int) -> dict:
        """Sample ``j``'s run, as `run_job` makes it."""
        met = self.points.met[j].tolist()
        rows = [
            _row(head, v, f, ok, absent)
            for head, v, f, ok, absent in zip(
                self.heads, self.values[j].tolist(), self.frequencies[j].tolist(), met, self.points.absent[j].tolist()
            )
        ]
        run = sample_run(self.samples[j], self.named, float(self.points.merit[j]), rows, self.seconds, self.worker)
        return run | {"attempts": 1}


def sample_run(
    head: Head,
    named: dict[str, float],
    ranking: float,
    rows: list[dict],
    seconds: float,
    worker: str = "local",
) -> dict:
    """A batched sample's run (``head``: its index, label and drawn values), as `run_job` makes it
    (``worker``: where it was computed)."""
    index, label, start = head
    return {
        "index": index,
        "label": label,
        "start": start,
        "worker": worker,
        "status": "running",
        "reason": "",
        "iterations": 0,
        "parameters": {**named, **start},
        "ranking": ranking,
        "measures": rows,
        "meets_requirements": all(row["satisfied"] for row in rows),
        "seconds": seconds,
    }


def _row(head: RowHead, value: float, frequency: float, ok: bool, absent: bool) -> dict:
    """A tableau row as `StepRecord.to_json` writes it (non-finite numbers as 'inf', '-inf', 'nan')."""
    return {
        "name": head.name,
        "kind": head.kind,
        "condition": head.condition,
        "value": number(value),
        "desired": number(head.desired),
        "satisfied": ok,
        "frequency": None if math.isnan(frequency) else number(frequency),
        "at_least": head.at_least,
        "method": absent_reason(head.kind, value) if absent else None,
    }


def number(value: float | None) -> float | str | None:
    """A number as the session's JSON writes it: non-finite ones as 'inf', '-inf', 'nan'."""
    return value if value is None or math.isfinite(value) else repr(value)

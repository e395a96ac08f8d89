"""The bounds of every numeric option of every subcommand, in one table, checked once
after parsing (`check_options`): a number outside its bounds, NaN or an infinity is
refused naming the option (``--points: -5 is not in 2..100000``), exit status 2,
before any work (``--points 1e8`` asked for 1.7 GB; ``--wmin 0`` reached geomspace)."""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

from sessions.format.limits import MAX_GRID_POINTS, MAX_SAMPLES, MAX_STARTS
from sessions.sweeps.named_clusters import MAX_JOBS
from tui.cli.common import CliError

MAX_ITERATIONS = 1_000_000  # of one run
MAX_SECONDS = 1e7  # a time limit or timeout (about four months)
MAX_DELAY = 1e6  # seconds of a loop delay


@dataclass(frozen=True)
class Bound:
    """A number's bounds: ``low <= x <= high`` (``above``: ``low < x``), finite."""

    low: float
    high: float
    above: bool = False

    def fault(self, x: float) -> str | None:
        """Why ``x`` is refused, or None."""
        if isinstance(x, float) and not math.isfinite(x):
            return "must be a finite number"
        if x < self.low or (self.above and x == self.low) or x > self.high:
            return f"is not {self._range()}" if self.high == math.inf or self.above else f"is not in {self._range()}"
        return None

    def _range(self) -> str:
        low, high = (f"{v:g}" if isinstance(v, float) else str(v) for v in (self.low, self.high))
        if self.high == math.inf:
            return f"> {low}" if self.above else f">= {low}"
        return f"{low} < x <= {high}" if self.above else f"{low}..{high}"


ANY = Bound(-math.inf, math.inf)
POSITIVE = Bound(0.0, math.inf, above=True)
SECONDS = Bound(0.0, MAX_SECONDS, above=True)

BOUNDS: dict[str, dict[str, Bound]] = {
    "analyze": {
        "gain": ANY,
        "delay": Bound(0.0, MAX_DELAY),
        "wmin": POSITIVE,
        "wmax": POSITIVE,
        "points": Bound(2, MAX_GRID_POINTS),
        "skew": ANY,
        "locus_range": ANY,
        "locus_points": Bound(2, 100_000),
        "sample_time": POSITIVE,
    },
    "run": {"iterations": Bound(1, MAX_ITERATIONS), "time_limit": SECONDS},
    "report": {"iteration": Bound(0, MAX_ITERATIONS)},
    "new": {"sample_time": POSITIVE},
    "export": {"iteration": Bound(0, MAX_ITERATIONS), "sample_time": POSITIVE},
    "compare": {"iterations": Bound(0, MAX_ITERATIONS)},
    "tune": {"pick": Bound(1, 10_000)},
    "tradeoff": {"values": ANY},
    "sweep": {
        "starts": Bound(1, MAX_STARTS),
        "spread": Bound(1.0, 1e6, above=True),
        "samples": Bound(1, MAX_SAMPLES),
        "seed": Bound(0, 2**32 - 1),
        "connect_timeout": SECONDS,
        "workers": Bound(1, 1024),
        "min_jobs": Bound(0, MAX_JOBS),
        "max_jobs": Bound(1, MAX_JOBS),
    },
}
ORDERED = {"analyze": [("wmin", "wmax")]}  # pairs that must be increasing (first < second)


def check_options(args: argparse.Namespace) -> None:
    """A `CliError` naming the first numeric option out of its bounds (or out of order)."""
    for dest, bound in BOUNDS.get(args.command, {}).items():
        value = getattr(args, dest, None)
        for x in value if isinstance(value, list | tuple) else [value]:
            fault = None if x is None else bound.fault(x)
            if fault is not None:
                raise CliError(f"{_flag(dest)}: {x!r} {fault}")
    for low, high in ORDERED.get(args.command, []):
        if getattr(args, low) >= getattr(args, high):
            raise CliError(f"{_flag(low)} {getattr(args, low)!r} must be below {_flag(high)} {getattr(args, high)!r}")
    ranges = getattr(args, "locus_range", None)
    if args.command == "analyze" and ranges is not None and ranges[0] >= ranges[1]:
        raise CliError(f"--locus-range: LO {ranges[0]!r} must be below HI {ranges[1]!r}")


def _flag(dest: str) -> str:
    return "--" + dest.replace("_", "-")

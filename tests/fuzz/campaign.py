"""A fuzz campaign: many cases, their outcomes counted and the failures grouped
by signature (the class of a bug, not the example that showed it)."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from tests.fuzz.corpus import Seed
from tests.fuzz.harness import Outcome, draw, execute

DEFAULT_SEED = 20261201
DEFAULT_CASES = 2000
DEFAULT_BUDGET = 10.0  # seconds a case may take before it counts as a hang


def setting(name: str, default: float) -> float:
    """A number from the environment (LOOPCRAFT_FUZZ_CASES, _SEED, _BUDGET), else the default."""
    text = os.environ.get(f"LOOPCRAFT_FUZZ_{name}")
    return type(default)(text) if text else default


@dataclass
class Tally:
    """Counts of outcomes, the failures by signature, and the slowest cases."""

    kinds: Counter = field(default_factory=Counter)
    commands: Counter = field(default_factory=Counter)
    failures: dict[str, list[Outcome]] = field(default_factory=lambda: defaultdict(list))
    seconds: float = 0.0
    slowest: list[tuple[float, int, str]] = field(default_factory=list)

    def add(self, outcome: Outcome) -> None:
        """Count one outcome."""
        self.kinds[outcome.kind] += 1
        self.commands[(outcome.case.command, outcome.kind)] += 1
        self.seconds += outcome.seconds
        self.slowest = sorted(
            self.slowest + [(outcome.seconds, outcome.case.index, outcome.case.origin)], reverse=True
        )[:5]
        if outcome.failed:
            self.failures[outcome.signature].append(outcome)

    @property
    def cases(self) -> int:
        return sum(self.kinds.values())

    def summary(self) -> str:
        """A few lines: totals, by command, the slowest cases, each failure class with one example."""
        lines = [
            f"{self.cases} cases in {self.seconds:.1f} s: "
            + ", ".join(f"{k} {n}" for k, n in sorted(self.kinds.items()))
        ]
        for command in ("report", "run", "replay"):
            counts = {k: n for (c, k), n in self.commands.items() if c == command}
            lines.append(f"  {command}: " + ", ".join(f"{k} {n}" for k, n in sorted(counts.items())))
        lines.append("  slowest: " + ", ".join(f"case {i} ({o}) {s:.2f} s" for s, i, o in self.slowest))
        for _signature, outcomes in sorted(self.failures.items(), key=lambda kv: -len(kv[1])):
            lines.append(f"{len(outcomes)} x " + outcomes[0].describe())
        return "\n".join(lines)


def run_cases(seeds: list[Seed], seed: int, indices: Iterable[int], budget: float, folder: Path | None = None) -> Tally:
    """Run the cases ``indices`` of fuzz run ``seed``, each in a fresh folder."""
    tally = Tally()
    root = Path(tempfile.mkdtemp(prefix="loopcraft-fuzz-")) if folder is None else folder
    try:
        for index in indices:
            case_folder = root / f"case{index}"
            tally.add(execute(draw(seeds, seed, index), case_folder, budget))
            shutil.rmtree(case_folder, ignore_errors=True)
    finally:
        if folder is None:
            shutil.rmtree(root, ignore_errors=True)
    return tally

"""Run a fuzz campaign, or reproduce one case:

python -m tests.fuzz --cases 20000            # a campaign, its summary
python -m tests.fuzz --seed S --case I -v     # one case: its files, its output, its traceback
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from tests.fuzz.campaign import DEFAULT_BUDGET, DEFAULT_CASES, DEFAULT_SEED, run_cases, setting
from tests.fuzz.corpus import build_corpus
from tests.fuzz.harness import draw, execute


def _one(seeds, seed: int, index: int, budget: float, keep: Path | None) -> int:
    folder = keep or Path(tempfile.mkdtemp(prefix="loopcraft-fuzz-case-"))
    case = draw(seeds, seed, index)
    outcome = execute(case, folder, budget)
    print(f"case {index} of seed {seed}: {case.origin}; {'; '.join(case.log) or 'unmutated'}")
    print(f"command: loopcraft {' '.join(case.argv(folder))}")
    print(f"outcome: {outcome.kind} in {outcome.seconds:.3f} s {outcome.signature}")
    print(f"stderr: {outcome.stderr.strip()[:2000]}")
    if outcome.detail:
        print(outcome.detail)
    print(f"files kept in {folder}")
    return 1 if outcome.failed else 0


def main(argv: list[str] | None = None) -> int:
    """The command line of the fuzzer."""
    parser = argparse.ArgumentParser(prog="python -m tests.fuzz")
    parser.add_argument("--seed", type=int, default=setting("SEED", DEFAULT_SEED))
    parser.add_argument("--cases", type=int, default=setting("CASES", DEFAULT_CASES))
    parser.add_argument("--start", type=int, default=0)
    parser.add_argument("--case", type=int, help="reproduce this one case")
    parser.add_argument("--budget", type=float, default=setting("BUDGET", DEFAULT_BUDGET))
    parser.add_argument("--keep", type=Path, help="write the case's files here")
    parser.add_argument("-v", action="store_true", help="(with --case) say everything")
    args = parser.parse_args(argv)
    seeds = build_corpus()
    if args.case is not None:
        return _one(seeds, args.seed, args.case, args.budget, args.keep)
    tally = run_cases(seeds, args.seed, range(args.start, args.start + args.cases), args.budget)
    print(tally.summary())
    return 1 if tally.failures else 0


if __name__ == "__main__":
    sys.exit(main())

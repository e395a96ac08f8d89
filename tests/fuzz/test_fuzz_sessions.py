"""Fuzz the command line with mutated bundled examples ("Nothing crashes,
nothing is lost"): `report`, `run --iterations 3 --out OTHER` and `replay`
on thousands of structure-aware mutants, each judged by `tests.fuzz.harness`.

`make test` runs LOOPCRAFT_FUZZ_CASES (default 600, a smoke run that keeps `make test` under
ten minutes) cases split by example; `make fuzz` runs 20 000 (`python -m tests.fuzz`: 2000).  A failure prints its seed and case number and the
command that reproduces it (`python -m tests.fuzz --seed S --case I -v`)."""

from __future__ import annotations

from functools import lru_cache

import pytest

from tests.fuzz.campaign import DEFAULT_BUDGET, DEFAULT_SEED, run_cases, setting
from tests.fuzz.corpus import EXAMPLES, Seed, build_corpus

CASES = int(setting("CASES", 600))
SEED = int(setting("SEED", DEFAULT_SEED))
BUDGET = float(setting("BUDGET", DEFAULT_BUDGET))


@lru_cache(maxsize=1)
def corpus() -> tuple[Seed, ...]:
    """The seed documents, built once per test session."""
    return tuple(build_corpus())


@pytest.mark.parametrize("example", sorted(p.stem for p in EXAMPLES.glob("*.json")))
def test_mutants_of_an_example_never_crash(example, tmp_path):
    seeds = list(corpus())
    indices = [i for i in range(CASES) if seeds[i % len(seeds)].name.split("+")[0] == example]
    assert indices, f"no case draws from {example}"
    tally = run_cases(seeds, SEED, indices, BUDGET, tmp_path)
    print(tally.summary())
    if tally.failures:
        pytest.fail(
            f"{sum(map(len, tally.failures.values()))} failing case(s) of {example}:\n"
            + "\n".join(f"{len(o)} x {o[0].describe()}" for o in tally.failures.values()),
            pytrace=False,
        )


def test_the_harness_sees_a_crash(tmp_path, monkeypatch):
    """An exception escaping main() is reported as a traceback, not passed over."""
    from tests.fuzz import harness

    def broken(argv):
        raise KeyError("boom")

    monkeypatch.setattr(harness, "main", broken)
    case = harness.draw(list(corpus()), SEED, 0)
    outcome = harness.execute(case, tmp_path, BUDGET)
    assert outcome.kind == "traceback" and "KeyError" in outcome.signature


def test_the_harness_sees_a_warning_and_a_hang(tmp_path, monkeypatch):
    """A RuntimeWarning fails a case that otherwise succeeds; so does running past the budget."""
    import time
    import warnings

    from tests.fuzz import harness

    def warns(argv):
        warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
        return 0

    def hangs(argv):
        time.sleep(5)
        return 0

    case = harness.draw(list(corpus()), SEED, 1)
    case.command = "report"
    monkeypatch.setattr(harness, "main", warns)
    assert harness.execute(case, tmp_path / "w", BUDGET).kind == "warning"
    monkeypatch.setattr(harness, "main", hangs)
    assert harness.execute(case, tmp_path / "h", 0.2).kind == "hang"

"""slp judged against brute force on seeded problems beyond the twenty of
tests/engine/test_brute_force.py (issue 51, section 5): at least 90 % of the problems brute
force solves are solved by slp from the template's start, and no run ends with an improving
step it does not name.  `make test` runs LOOPCRAFT_FUZZ_BRUTE_FORCE_CASES (default 30, about
20 s) of them, `make fuzz` 280 (seeds 20..299: 300 problems with the twenty)."""

from __future__ import annotations

from tests.engine.brute_force import judged
from tests.fuzz.campaign import setting

FIRST = 20  # seeds 0..19 are tests/engine/test_brute_force.py's
SEEDS = range(FIRST, FIRST + int(setting("BRUTE_FORCE_CASES", 30)))


def test_slp_meets_what_brute_force_meets_on_many_problems():
    outcomes = [judged(seed) for seed in SEEDS]
    feasible = [o for o in outcomes if o.brute_force_meets_all]
    reached = [o.seed for o in feasible if o.slp_meets_all]
    missed = sorted({o.seed for o in feasible} - set(reached))
    assert len(reached) >= 0.9 * len(feasible), f"slp missed {missed} of {len(feasible)}"
    assert [o.unnamed for o in outcomes if o.unnamed] == []

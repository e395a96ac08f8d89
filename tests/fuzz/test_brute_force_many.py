"""slp judged against brute force on a few hundred seeded problems (issue 51, section 5; the
twenty of tests/engine/test_brute_force.py are the first of them): at least 90 % of the
problems brute force solves are solved by slp from the template's start, and no run ends with
an improving step it does not name."""

from __future__ import annotations

from tests.engine.brute_force import judged

SEEDS = range(300)


def test_slp_meets_what_brute_force_meets_on_many_problems():
    outcomes = [judged(seed) for seed in SEEDS]
    feasible = [o for o in outcomes if o.brute_force_meets_all]
    reached = [o.seed for o in feasible if o.slp_meets_all]
    missed = sorted({o.seed for o in feasible} - set(reached))
    assert len(reached) >= 0.9 * len(feasible), f"slp missed {missed} of {len(feasible)}"
    assert [o.unnamed for o in outcomes if o.unnamed] == []

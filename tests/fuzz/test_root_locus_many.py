"""Gain loci of random loops beyond the seeds of tests/engine/test_root_locus.py (its
`check_gain_locus`: every point a root of D + k N to 1e-9, every axis crossing a gain margin).
`make fuzz` runs LOOPCRAFT_FUZZ_LOCUS_CASES (80: seeds 20..99); unset, `make test` skips it (the
twenty-one seeds there keep `make test` under ten minutes)."""

from __future__ import annotations

import pytest

from tests.engine.test_root_locus import SEEDS as TESTED
from tests.engine.test_root_locus import check_gain_locus
from tests.fuzz.campaign import setting

FIRST = 20
SEEDS = [seed for seed in range(FIRST, FIRST + int(setting("LOCUS_CASES", 0))) if seed not in TESTED]


@pytest.mark.skipif(not SEEDS, reason="make fuzz runs it (LOOPCRAFT_FUZZ_LOCUS_CASES)")
@pytest.mark.parametrize("seed", SEEDS or [None])
def test_gain_locus_points_solve_the_characteristic_equation_on_many_loops(seed):
    check_gain_locus(seed)

"""Pole lists of loops with 48-60 poles beyond the six seeds of tests/engine/test_many_pole_loops.py,
each against mpmath's roots computed here (10-110 s a loop).  `make fuzz` runs
LOOPCRAFT_FUZZ_MANY_POLE_CASES (30: seeds 300..329); unset, `make test` skips it."""

from __future__ import annotations

import warnings

import pytest

from tests.engine.many_pole_loops import check_pole_list, exact_poles, many_pole_loop
from tests.fuzz.campaign import setting

FIRST = 300
SEEDS = list(range(FIRST, FIRST + int(setting("MANY_POLE_CASES", 0))))


@pytest.mark.skipif(not SEEDS, reason="make fuzz runs it (LOOPCRAFT_FUZZ_MANY_POLE_CASES)")
@pytest.mark.parametrize("seed", SEEDS or [None])
def test_pole_lists_of_many_pole_loops_are_the_exact_roots(seed):
    loop = many_pole_loop(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_pole_list(loop, exact_poles(loop))

"""Closed-loop pole lists of loops with 48-60 poles typed as one expression (issue 49, section 3):
six seeds of tests/engine/many_pole_loops.py against mpmath's roots of D + K N multiplied out
exactly (data/many_pole_loops.json, written by data/make_many_pole_loops.py: minutes); `make fuzz`
runs more seeds, their references computed there (tests/fuzz/test_many_pole_loops.py)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from tests.engine.many_pole_loops import check_pole_list, many_pole_loop

CASES = json.loads((Path(__file__).parent / "data" / "many_pole_loops.json").read_text())


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"seed{c['seed']}")
def test_the_pole_list_is_the_exact_roots(case: dict) -> None:
    loop = many_pole_loop(case["seed"])
    assert loop.text == case["text"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_pole_list(loop, np.array([complex(re, im) for re, im in case["poles"]]))

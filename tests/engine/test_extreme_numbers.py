"""Expressions whose numbers reach the ends of the floating-point range (issue 35, section 7):
a clear EngineError naming the expression, or an answer, never ValueError, LinAlgError or
OverflowError from the realization, the pole-zero form or the search's grid."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback
from engine.errors import EngineError

EXTREMES = ["1e308", "1e-308", "5e-324", "1e-320", "1.7e308", "1e300", "1e-300", "1e10", "0", "1"]
GRID = np.logspace(-3, 3, 200)


def _expression(rng: np.random.Generator) -> str:
    def number() -> str:
        return str(rng.choice(EXTREMES)) if rng.random() < 0.6 else f"{rng.uniform(-10, 10):.3g}"

    def term(depth: int) -> str:
        kind = rng.integers(0, 5 if depth < 3 else 2)
        if kind == 0:
            return number()
        if kind == 1:
            return f"(s+{number()})"
        if kind == 2:
            return f"{term(depth + 1)}*{term(depth + 1)}"
        if kind == 3:
            return f"({term(depth + 1)})**{int(rng.integers(1, 16))}"
        return f"({term(depth + 1)}-{term(depth + 1)})"

    return f"{term(0)}/({term(0)})"


@pytest.mark.parametrize(
    "text",
    [
        "-s/100/(s+1e308)",
        "s*5e-324*(0-7.25*1e3*s)^1-1e-3",
        "((s))**1.5e1/(0-1e308)**2.0",
        "(s+1e-320)/(s+1)**2",
        "1e300*(s+1e10)**3/(s+1)**4",
    ],
)
def test_the_fuzzers_examples_end_cleanly(text: str) -> None:
    _ends_cleanly(text)


@pytest.mark.long
def test_random_extreme_expressions_end_cleanly() -> None:
    rng = np.random.default_rng(35)
    for _ in range(150):
        _ends_cleanly(_expression(rng))


def _ends_cleanly(text: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            analyze(unity_feedback([text]), "e", GRID, {})
        except EngineError as exc:
            assert str(exc), text

"""The pole-zero form of a compensator typed by its polynomial coefficients (cip's form,
`PolynomialTransfer`): read off the coefficients, with no form of each term and no
evaluation of the sum term by term (a drag of such a root computes about twenty forms a
move), and the same form as the general reading of the tree."""

from __future__ import annotations

import numpy as np
import pytest

from engine.model import factored
from engine.model.blocks import PolynomialTransfer
from engine.model.expressions import Expression

NUMERATOR = ("x0", "x1", "x2", 0.5)
DENOMINATOR = ("y0", "y1", "y2")
VALUES = {"x0": 1.0, "x1": 11.7944, "x2": 28.592, "y0": 1.0, "y1": 21.565, "y2": 6.0565}


def _reversed_terms(coefficients: tuple) -> str:
    """The polynomial with each term written x**k*c: the general reading (each term's form)."""
    return " + ".join(f"s**{k}*{c!r}" if isinstance(c, float) else f"s**{k}*{c}" for k, c in enumerate(coefficients))


def test_a_typed_polynomial_s_form_evaluates_no_sum_term_by_term(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = []
    at = factored._at
    monkeypatch.setattr(factored, "_at", lambda *a: calls.append(1) or at(*a))
    transfer = PolynomialTransfer(NUMERATOR, DENOMINATOR)
    form = factored.pole_zero(transfer.expression, VALUES)
    assert calls == []  # before: two (the origin's check of each sum)
    assert form.zeros.size == 3 and form.poles.size == 2


@pytest.mark.parametrize("seed", range(5))
def test_a_typed_polynomial_s_form_is_the_general_reading_s(seed: int) -> None:
    rng = np.random.default_rng(seed)
    values = {name: float(rng.normal() * 10.0 ** rng.integers(-2, 3)) for name in VALUES}
    transfer = PolynomialTransfer(NUMERATOR, DENOMINATOR)
    general = Expression(f"({_reversed_terms(NUMERATOR)})/({_reversed_terms(DENOMINATOR)})")
    fast, slow = factored.pole_zero(transfer.expression, values), factored.pole_zero(general, values)
    assert fast.gain == slow.gain
    assert np.array_equal(fast.zeros, slow.zeros) and np.array_equal(fast.poles, slow.poles)
    numerator = [values.get(c, c) if isinstance(c, str) else c for c in NUMERATOR][::-1]
    expected = np.sort_complex(np.roots(numerator))  # numpy's roots of the coefficients
    assert np.allclose(np.sort_complex(fast.zeros), expected, rtol=1e-12)

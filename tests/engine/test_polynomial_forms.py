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


def _forms_counted(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Every pole-zero form computed (not read from an expression's store), counted."""
    calls: list[int] = []
    checked = factored._checked
    monkeypatch.setattr(factored, "_checked", lambda *a: calls.append(1) or checked(*a))
    return calls


PAIRED = {"x0": 100.0, "x1": 6.0572, "x2": 7.5664, "y0": 100.0, "y1": 10.065, "y2": 6.3288}  # the vehicle's second


@pytest.mark.parametrize(
    ("values", "item", "factor"),
    [(VALUES, "zero1", 1.3), (VALUES, "zero2", 0.9), (VALUES, "pole2", 0.8), (PAIRED, "zeropair1", 1.2)],
)
def test_a_root_of_typed_coefficients_moves_in_closed_form_checked_by_one_form(
    monkeypatch: pytest.MonkeyPatch, values: dict, item: str, factor: float
) -> None:
    from engine.design.compensator_items import items, named
    from engine.design.compensator_moves import moved

    transfer = PolynomialTransfer(("x0", "x1", "x2"), DENOMINATOR)
    found = items(transfer, values)
    index = named(found).index(item)
    forms = _forms_counted(monkeypatch)
    target = abs(found[index].root) * factor
    solved = moved(transfer, values, index, target, bounds={"x0": (1.0, 1.0), "y0": (1.0, 1.0)}, found=found)
    assert len(forms) <= 1  # the least squares over the coefficients: twelve to sixteen
    after = {**values, **solved}
    side = ("x0", "x1", "x2") if item.startswith("zero") else DENOMINATOR
    roots, old = (np.roots([v[c] for c in side][::-1]) for v in (after, values))  # numpy's roots of the coefficients
    root = found[index].root
    for r in old:
        if min(abs(r - root), abs(r - root.conjugate())) > 1e-9 * abs(r):  # every other root kept
            assert np.min(np.abs(roots - r)) <= 1e-9 * abs(r)
    assert np.min(np.abs(np.abs(roots) - target)) <= 1e-9 * target
    if item.endswith("pair"):
        assert np.allclose(np.abs(roots.real) / np.abs(roots), -root.real / abs(root), rtol=1e-9)  # its damping kept
    assert after[side[0]] == values[side[0]]  # the Bode gain kept: the constant terms as they were


def test_moves_by_the_secant_or_in_closed_form_import_no_optimizer() -> None:
    """scipy.optimize takes 1.4 s to import: a drag's first move waited for it (1.47 s to
    the first frame on the lead, 0.81 s now at load 6), though only the bracket's and the
    least squares' fallbacks use it."""
    import subprocess
    import sys

    program = """
import sys
from engine.design.compensator_items import items, named
from engine.design.compensator_moves import moved
from engine.model.blocks import ExpressionTransfer, PolynomialTransfer
lead, values = ExpressionTransfer("K*(1 + T1*s)/(1 + T2*s)"), {"K": 2.0, "T1": 1.0, "T2": 0.1}
assert set(moved(lead, values, 1, 1.3)) == {"T1"}  # the zero at 1/T1: Newton-secant steps
cip = PolynomialTransfer(("x0", "x1", "x2"), ("y0", "y1", "y2"))
values = {"x0": 1.0, "x1": 11.7944, "x2": 28.592, "y0": 1.0, "y1": 21.565, "y2": 6.0565}
found = items(cip, values)
assert set(moved(cip, values, named(found).index("zero1"), 0.13, bounds={"x0": (1.0, 1.0)})) == {"x1", "x2"}
print("scipy.optimize" in sys.modules)
"""
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120, check=True)
    assert done.stdout.strip() == "False"

"""The safe expression parser: grammar, positions in errors, values and derivatives."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import ExpressionError, ParameterError
from engine.model.expressions import Expression


def test_rational_of_report_003_loop():
    r = Expression("16000/(s*(s+8)*(s+20))").rational({})
    np.testing.assert_allclose(r.num, [16000.0])
    np.testing.assert_allclose(r.den, [1.0, 28.0, 160.0, 0.0])


def test_w_plane_expression():
    r = Expression("0.77*(1-w)*(1-0.136*w)/(w*(1+w))", "w").rational({})
    np.testing.assert_allclose(r.num, 0.77 * np.polymul([-1, 1], [-0.136, 1]))
    np.testing.assert_allclose(r.den, [1.0, 1.0, 0.0])


def test_named_parameters_and_powers():
    e = Expression("K*(1+T1*s)/(1+T2*s)^2 + s**-1")
    assert e.parameters == ("K", "T1", "T2")
    s = 2j
    value = e.evaluate(np.array([s]), {"K": 3.0, "T1": 0.5, "T2": 0.1}).value[0]
    assert value == pytest.approx(3 * (1 + 0.5 * s) / (1 + 0.1 * s) ** 2 + 1 / s)


def test_parameter_expression_value():
    assert Expression("2*zeta*omega").value({"zeta": 0.5, "omega": 4.0}) == pytest.approx(4.0)


@pytest.mark.parametrize(
    "text, message, column",
    [
        ("2s+1", r"write 2\*s for a product", 2),  # the place where the '*' is missing
        ("s**0.5", "exponent must be an integer constant", 4),
        ("__import__('os')", "function calls are not allowed", 11),
        ("16000/(s*(s+8)(s+20))", "function calls are not allowed", 15),
        ("s % 2", "unsupported operator 'Mod'", 1),
        ("s+", r"'\+' at the end has nothing after it", 2),
        ("", "empty expression", None),
        ("lambda: 1", "unsupported element 'Lambda'", 1),
        ("s.real", "unsupported element 'Attribute'", 1),
        ("[1, 2]", "unsupported element 'List'", 1),
        ("1e400", "non-finite number", 1),
        ("z + s", "variable 'z' in an expression in 's'", 1),
        ("True", "unsupported constant", 1),
    ],
)
def test_errors_name_the_offending_token_and_column(text, message, column):
    with pytest.raises(ExpressionError, match=message) as info:
        Expression(text)
    if column is not None:
        assert info.value.position == column - 1
        assert f"column {column}" in str(info.value)


def test_missing_parameter():
    with pytest.raises(ParameterError, match="T2"):
        Expression("K/(1+T2*s)").rational({"K": 1.0})


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet="s+-*/()^.0123456789 KTabcimport_[]'\"=,;:", max_size=30))
def test_parser_only_raises_expression_errors(text):
    try:
        Expression(text)
    except ExpressionError:
        pass


@pytest.mark.parametrize("name", ["K", "T1", "T2"])
def test_forward_derivatives_equal_central_differences(name):
    e = Expression("K*(1+T1*s)**2/((1+T2*s)*(s**2+T2*s+K))")
    params = {"K": 2.0, "T1": 0.3, "T2": 0.7}
    x = 1j * np.geomspace(0.1, 100, 30)
    analytic = e.evaluate(x, params, with_dvar=True)
    h = 1e-5 * params[name]
    up, down = dict(params), dict(params)
    up[name] += h
    down[name] -= h
    numeric = (e.evaluate(x, up).value - e.evaluate(x, down).value) / (2 * h)
    np.testing.assert_allclose(analytic.grad[name], numeric, rtol=1e-7)
    dx = 1e-6 * np.abs(x)
    numeric_s = (e.evaluate(x + dx, params).value - e.evaluate(x - dx, params).value) / (2 * dx)
    np.testing.assert_allclose(analytic.dvar, numeric_s, rtol=1e-6)


def test_the_fraction_is_the_expression_and_finite_at_its_poles():
    """`Expression.fraction`: N/D and its quotient-rule derivatives are `evaluate`'s (nested
    quotients, negative powers), and at a pole, where `evaluate` divides by zero, D is 0 with
    D' and dD/dparameter finite (closed forms: K/((s + b)^2 (1 + s/c)) is K c / ((s + b)^2 (c + s)))."""
    import numpy as np

    e = Expression("K*(1+T*s)/((s+b)^2*(1+s/c)) - a/s^2 + (s+b)^-1")
    params = {"K": 2.0, "T": 1.5, "b": 0.5, "c": 4.0, "a": 0.7}
    x = np.array([0.3 + 0.2j, -2.0, 1j])
    num, den = e.fraction(x, params)
    full = e.evaluate(x, params, with_dvar=True)
    assert np.allclose(num.value / den.value, full.value, rtol=1e-13)
    assert np.allclose((num.dvar * den.value - den.dvar * num.value) / den.value**2, full.dvar, rtol=1e-12)
    for name in params:
        dn, dd = num.grad.get(name, 0.0), den.grad.get(name, 0.0)
        assert np.allclose((dn * den.value - dd * num.value) / den.value**2, full.grad[name], rtol=1e-12)
    pole = np.array([-0.5 + 0j])
    num, den = Expression("K/((s+b)^2*(1+s/c))").fraction(pole, params)
    assert den.value[0] == 0 and num.value[0] == 2.0 * 4.0 and den.dvar[0] == 0  # a double root of D
    num, den = Expression("K/((s+b)*(1+s/c))").fraction(pole, params)
    assert den.dvar[0] == pytest.approx(4.0 - 0.5) and den.grad["b"][0] == pytest.approx(4.0 - 0.5)  # (c + s)

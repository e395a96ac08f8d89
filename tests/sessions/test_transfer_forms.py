"""Every transfer kind's one-line text reads back to the same model."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sessions.format.schema import (
    ControllerBlock,
    ControllerFactorModel,
    DelayBlock,
    FactoredBlock,
    FactorModel,
    PolynomialBlock,
)
from sessions.forms.transfers import format_transfer, parse_transfer, quote_name, split_names

numbers = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False).filter(lambda v: abs(v) > 1e-300 or v == 0)
names = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,6}", fullmatch=True).filter(
    lambda n: n.lower() not in ("inf", "nan", "infinity", "zeros", "poles", "gain")
)
coefficients = st.one_of(numbers, names)
positive = st.one_of(st.floats(min_value=1e-6, max_value=1e6), names)
factors = st.one_of(
    st.builds(lambda a: FactorModel(kind="root", a=a), st.one_of(numbers, names)),
    st.builds(lambda t: FactorModel(kind="time_constant", T=t), coefficients),
    st.builds(lambda z, w: FactorModel(kind="second_order", zeta=z, omega=w), positive, positive),
)
controller_factors = st.one_of(
    st.builds(lambda k, b: ControllerFactorModel(kind=k, b=b), st.sampled_from(["zero", "pole"]), coefficients),
    st.builds(
        lambda k, z, w: ControllerFactorModel(kind=k, damping=z, frequency=w),
        st.sampled_from(["complex_zero", "complex_pole"]),
        coefficients,
        coefficients,
    ),
)
powers = st.integers(-4, 4)
transfers = st.one_of(
    st.builds(
        lambda g, p, z, q: FactoredBlock(kind="factored", gain=g, s_power=p, zeros=z, poles=q),
        coefficients,
        powers,
        st.lists(factors, max_size=4),
        st.lists(factors, max_size=4),
    ),
    st.builds(
        lambda g, p, f: ControllerBlock(kind="controller", gain=g, s_power=p, factors=f),
        coefficients,
        powers,
        st.lists(controller_factors, max_size=4),
    ),
    st.builds(
        lambda n, d, o: PolynomialBlock(kind="polynomial", numerator=n, denominator=d, order=o),
        st.lists(coefficients, min_size=1, max_size=5),
        st.lists(coefficients, min_size=1, max_size=5),
        st.sampled_from(["ascending", "descending"]),
    ),
    st.builds(lambda t: DelayBlock(kind="delay", tau=t), st.one_of(st.floats(0, 1e3), names)),
)


@pytest.mark.slow
@settings(max_examples=300)
@given(transfers, st.sampled_from(["s", "w"]))
def test_the_text_of_a_transfer_reads_back(transfer, variable):
    text = format_transfer(transfer, variable)
    assert parse_transfer(text, variable) == transfer, text


@given(st.lists(st.from_regex(r"[a-z][a-z _]{0,8}[a-z]", fullmatch=True), min_size=3, max_size=3))
def test_names_with_spaces_are_quoted_and_split_back(words):
    names, rest = split_names(" ".join(quote_name(w) for w in words) + " 1/(s+1)", 3)
    assert names == words and rest == "1/(s+1)"


def test_an_expression_is_an_expression_block_and_errors_say_the_form():
    assert parse_transfer("10/(s+1)", "s").expression == "10/(s+1)"
    for text, message in [
        ("factored: gain 1; poles (s+)", "factors are"),
        ("controller: zero 1", "its gain"),
        ("polynomial: num 1", "den"),
        ("table: a.csv polar hz", "FILE columns"),
        ("factored: gain 1; poles sos(-1, 2)", "zeta"),
    ]:
        try:
            parse_transfer(text, "s")
        except ValueError as exc:
            assert message in str(exc), (text, str(exc))
        else:
            raise AssertionError(f"{text!r} was read")

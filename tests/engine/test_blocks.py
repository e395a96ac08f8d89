"""Blocks: polynomial orders, factored shorthand, tables and their interpolation, delay."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from engine.errors import BlockError, ExtrapolationError
from engine.model.blocks import (
    DelayTransfer,
    ExpressionTransfer,
    Factor,
    FrequencyTable,
    factored_transfer,
    polynomial_transfer,
)

SHARED = (
    Path(__file__).resolve().parents[2] / "sessions" / "examples" / "seidel_inlet_table1.csv"
)  # the bundled copy of the clean Table I
X = 1j * np.geomspace(0.1, 100, 40)


def test_ascending_and_descending_coefficients_are_the_same_block():
    up = polynomial_transfer([1.0, 2.0], [3.0, 4.0, 5.0], order="ascending")
    down = polynomial_transfer([2.0, 1.0], [5.0, 4.0, 3.0], order="descending")
    expected = (1 + 2 * X) / (3 + 4 * X + 5 * X**2)
    np.testing.assert_allclose(up.evaluate(X, {}).value, expected, rtol=1e-14)
    np.testing.assert_allclose(down.evaluate(X, {}).value, expected, rtol=1e-14)


def test_polynomial_with_named_coefficients():
    block = polynomial_transfer(["x0", "x1"], ["y0", 1.0], order="ascending")
    assert block.parameters == ("x0", "x1", "y0")
    value = block.evaluate(X, {"x0": 2.0, "x1": 0.5, "y0": 4.0}).value
    np.testing.assert_allclose(value, (2 + 0.5 * X) / (4 + X), rtol=1e-14)


def test_factored_shorthand():
    block = factored_transfer(
        gain="K",
        s_power=-1,
        zeros=[Factor("time_constant", T=0.5)],
        poles=[Factor("root", a=3.0), Factor("second_order", zeta="z2", omega="w2")],
    )
    p = {"K": 7.0, "z2": 0.1, "w2": 20.0}
    expected = 7 * (1 + 0.5 * X) / (X * (X + 3) * (X**2 / 400 + 2 * 0.1 * X / 20 + 1))
    np.testing.assert_allclose(block.evaluate(X, p).value, expected, rtol=1e-13)


def test_improper_block_is_named():
    with pytest.raises(BlockError, match="improper"):
        ExpressionTransfer("s**2/(s+1)").check_proper({}, "block 'D'")


def test_table_interpolates_log_magnitude_and_unwrapped_phase():
    # |G| = 1/w (a line in log-log), phase -90 - 100*log10(w) deg crossing -180 (unwrap needed)
    w = np.geomspace(0.1, 100.0, 7)
    table = FrequencyTable.from_polar(w, 1 / w, -90 - 100 * np.log10(w))
    wi = np.geomspace(0.1, 100.0, 50)
    g = table.interpolate(wi)
    np.testing.assert_allclose(np.abs(g), 1 / wi, rtol=1e-12)
    expected_phase = np.radians(-90 - 100 * np.log10(wi))
    np.testing.assert_allclose(np.exp(1j * np.angle(g)), np.exp(1j * expected_phase), atol=1e-12)


def test_table_refuses_to_extrapolate():
    table = FrequencyTable.from_polar([1.0, 10.0], [1.0, 0.1], [0.0, -90.0], source="G1")
    with pytest.raises(ExtrapolationError, match="G1: frequency 20 rad/s is outside the data"):
        table.interpolate([5.0, 20.0])


@pytest.mark.parametrize(
    "freq, mag, message",
    [
        ([1.0, 1.0], [1.0, 1.0], "increase strictly"),
        ([0.0, 1.0], [1.0, 1.0], "must be > 0"),
        ([1.0, np.nan], [1.0, 1.0], "non-finite"),
        ([1.0, 2.0], [1.0, 0.0], "zero magnitude in row 2"),
    ],
)
def test_bad_tables(freq, mag, message):
    with pytest.raises(BlockError, match=message):
        FrequencyTable.from_polar(freq, mag, [0.0, 0.0])


def test_inlet_table_of_report_001_with_its_gains():
    """Table I of 001: normalized G1 times 0.016, frequencies in Hz."""
    with SHARED.open() as fh:
        rows = list(csv.reader(line for line in fh if not line.startswith("#")))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    hz = data[:, header.index("hz")]
    g1 = FrequencyTable.from_polar(
        hz, data[:, header.index("g1_mag")], data[:, header.index("g1_phase_deg")], unit="hz", gain=0.016, source="G1"
    )
    np.testing.assert_allclose(g1.omega, 2 * np.pi * hz)
    at_60hz = g1.interpolate([2 * np.pi * 60])[0]
    assert abs(at_60hz) == pytest.approx(0.016 * 0.326)
    assert np.degrees(np.angle(at_60hz)) == pytest.approx(-55.0)


def test_cartesian_table():
    t = FrequencyTable.from_cartesian([1.0, 2.0], [1.0, 0.0], [0.0, -1.0], gain=2.0)
    np.testing.assert_allclose(t.response, [2.0, -2.0j])


def test_delay_block():
    d = DelayTransfer("tau")
    dual = d.evaluate(X, {"tau": 0.01}, with_dvar=True)
    np.testing.assert_allclose(dual.value, np.exp(-X * 0.01))
    np.testing.assert_allclose(dual.grad["tau"], -X * np.exp(-X * 0.01))
    np.testing.assert_allclose(dual.dvar, -0.01 * np.exp(-X * 0.01))
    with pytest.raises(BlockError):
        DelayTransfer(-1.0)


def test_zero_denominator_is_refused_at_once():
    with pytest.raises(BlockError, match="denominator is identically zero"):
        ExpressionTransfer("1/(s - s)")

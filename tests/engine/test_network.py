"""Interconnections: diagram and matrix format agree, sensitivities equal
central finite differences, and bad diagrams give typed, named errors."""

from __future__ import annotations

import numpy as np
import pytest

from engine.errors import GridError, InterconnectionError, ParameterError
from engine.loop.responses import closed_loop, open_loop
from engine.model.blocks import (
    DelayTransfer,
    ExpressionTransfer,
    Factor,
    FrequencyTable,
    TabulatedTransfer,
    factored_transfer,
    polynomial_transfer,
)
from engine.model.network import Block, Junction, block_diagram, matrix_format, solve

OMEGA = np.geomspace(0.3, 80.0, 60)
PARAMS = {
    "K": 2.0,
    "T1": 0.4,
    "T2": 0.05,
    "wa": 40.0,
    "za": 0.35,
    "Kr": 0.3,
    "Tr": 0.02,
    "tau": 0.004,
    "x0": 1.0,
    "x1": 0.08,
    "g": 1.7,
}


def multi_loop_diagram():
    """An autopilot-like diagram: outer attitude loop with a lead compensator,
    inner rate loop, second-order actuator, a tabulated airframe, a delay,
    a polynomial filter (ascending coefficients) and a factored gain block."""
    w = np.geomspace(0.1, 100.0, 300)
    airframe = FrequencyTable.from_polar(
        w, 3.0 / np.sqrt(1 + (w / 2.0) ** 2), -np.degrees(np.arctan(w / 2.0)), source="airframe"
    )
    blocks = [
        Block("lead", "e", "u", ExpressionTransfer("K*(1+T1*s)/(1+T2*s)")),
        Block("actuator", "u2", "d", factored_transfer(poles=[Factor("second_order", zeta="za", omega="wa")])),
        Block("airframe", "d", "p", TabulatedTransfer(airframe)),
        Block("delay", "p", "pd", DelayTransfer("tau")),
        Block(
            "integrator",
            "pd",
            "y",
            factored_transfer(
                gain="g", s_power=-1, zeros=[Factor("root", a=5.0)], poles=[Factor("time_constant", T=0.1)]
            ),
        ),
        Block("gyro", "pd", "q", ExpressionTransfer("Kr/(1+Tr*s)")),
        Block("filter", "q", "qf", polynomial_transfer(["x0"], ["x0", "x1"], order="ascending")),
    ]
    junctions = [Junction("outer", "e", ((1.0, "r"), (-1.0, "y"))), Junction("inner", "u2", ((1.0, "u"), (-1.0, "qf")))]
    return block_diagram(blocks, junctions, inputs=["r"])


def central_difference(fun, params, name):
    h = 1e-4 * max(abs(params[name]), 1e-3)  # truncation ~1e-9, round-off ~1e-11 relative
    up, down = dict(params), dict(params)
    up[name] += h
    down[name] -= h
    return (fun(up) - fun(down)) / (2 * h)


def assert_close_columns(analytic, numeric):
    scale = np.max(np.abs(numeric))
    np.testing.assert_allclose(analytic, numeric, rtol=1e-6, atol=1e-9 * scale)


@pytest.mark.parametrize("name", sorted(PARAMS))
def test_open_loop_sensitivities_equal_central_differences(name):
    net = multi_loop_diagram()
    response = open_loop(net, "e", OMEGA, PARAMS)
    numeric = central_difference(lambda p: open_loop(net, "e", OMEGA, p, sensitivities=False).value, PARAMS, name)
    assert_close_columns(response.sensitivity[:, response.parameters.index(name)], numeric)


@pytest.mark.parametrize("name", sorted(PARAMS))
def test_every_signal_sensitivity_equals_central_differences(name):
    net = multi_loop_diagram()
    sol = solve(net, OMEGA, PARAMS, "r")
    numeric = central_difference(lambda p: solve(net, OMEGA, p, "r", sensitivities=False).x, PARAMS, name)
    assert_close_columns(sol.dx[:, :, sol.parameters.index(name)], numeric)


def test_frequency_derivative_equals_central_differences():
    net = block_diagram(
        [
            Block("lead", "e", "u", ExpressionTransfer("K*(1+T1*s)/(1+T2*s)")),
            Block("plant", "u", "y", ExpressionTransfer("wa**2/(s*(s**2+2*za*wa*s+wa**2))")),
            Block("delay", "y", "yd", DelayTransfer("tau")),
        ],
        [Junction("sum", "e", ((1.0, "r"), (-1.0, "yd")))],
        ["r"],
    )
    sol = solve(net, OMEGA, PARAMS, "e", break_at="e", sensitivities=False, d_omega=True)
    h = 1e-5 * OMEGA
    up = solve(net, OMEGA + h, PARAMS, "e", break_at="e", sensitivities=False).x
    down = solve(net, OMEGA - h, PARAMS, "e", break_at="e", sensitivities=False).x
    assert_close_columns(sol.dx_domega, (up - down) / (2 * h[:, None]))


def test_open_loop_of_unity_feedback_is_the_forward_path():
    net = block_diagram(
        [Block("G", "e", "y", ExpressionTransfer("10/(s*(s+1))"))],
        [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))],
        ["r"],
    )
    gh = open_loop(net, "e", OMEGA, {}).value
    np.testing.assert_allclose(gh, 10 / (1j * OMEGA * (1j * OMEGA + 1)), rtol=1e-13)
    t = closed_loop(net, "r", "y", OMEGA, {}).value
    np.testing.assert_allclose(t, gh / (1 + gh), rtol=1e-12)


def test_matrix_format_equals_block_diagram():
    """COEBRA matrix rows: e + y = theta; u - C e = 0; den(P) y - num(P) u = 0 (improper entries)."""
    signals = ["e", "u", "y"]
    entries = {
        (1, 1): "1",
        (1, 3): "1",
        (2, 2): "1",
        (2, 1): "-K*(1+T1*s)/(1+T2*s)",
        (3, 3): "s**2 + 2*za*wa*s + wa**2",
        (3, 2): "-wa**2",
    }
    mat = matrix_format(signals, entries, forcing_row=1)
    dia = block_diagram(
        [
            Block("C", "e", "u", ExpressionTransfer("K*(1+T1*s)/(1+T2*s)")),
            Block("P", "u", "y", ExpressionTransfer("wa**2/(s**2+2*za*wa*s+wa**2)")),
        ],
        [Junction("sum", "e", ((1.0, "theta"), (-1.0, "y")))],
        ["theta"],
    )
    for signal in signals:
        a = closed_loop(mat, "theta", signal, OMEGA, PARAMS)
        b = closed_loop(dia, "theta", signal, OMEGA, PARAMS)
        np.testing.assert_allclose(a.value, b.value, rtol=1e-12)
        order = [b.parameters.index(p) for p in a.parameters]
        np.testing.assert_allclose(a.sensitivity, b.sensitivity[:, order], rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(
        open_loop(mat, "e", OMEGA, PARAMS).value, open_loop(dia, "e", OMEGA, PARAMS).value, rtol=1e-12
    )


def test_unknown_signal_is_named():
    with pytest.raises(InterconnectionError, match="block 'G' reads signal 'ee'"):
        block_diagram([Block("G", "ee", "y", ExpressionTransfer("1/s"))], [], ["r"])


def test_two_producers_are_named():
    with pytest.raises(InterconnectionError, match="produced by both block 'A' and block 'B'"):
        block_diagram(
            [Block("A", "r", "y", ExpressionTransfer("1/s")), Block("B", "r", "y", ExpressionTransfer("2/s"))],
            [],
            ["r"],
        )


def test_matrix_without_diagonal_is_refused():
    with pytest.raises(InterconnectionError, match=r"row 2 has no diagonal entry a\[2,2\]"):
        matrix_format(["a", "b"], {(1, 1): "1", (2, 1): "1"}, forcing_row=1)


def test_singular_interconnection_names_the_frequency():
    # y = 1/(s^2+4) e and e = r - y ... fine; but a pole of a block on the grid is refused
    net = block_diagram(
        [Block("G", "e", "y", ExpressionTransfer("1/(s**2+4)"))],
        [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))],
        ["r"],
    )
    with pytest.raises(InterconnectionError, match="not finite at 2 rad/s"):
        open_loop(net, "e", np.array([1.0, 2.0, 3.0]), {})
    # algebraic loop y = e, e = r + y is singular at every frequency
    loop = block_diagram(
        [Block("G", "e", "y", ExpressionTransfer("1"))], [Junction("sum", "e", ((1.0, "r"), (1.0, "y")))], ["r"]
    )
    with pytest.raises(InterconnectionError, match="singular at 1 rad/s"):
        closed_loop(loop, "r", "y", np.array([1.0, 2.0]), {})


@pytest.mark.parametrize(
    "grid, message",
    [
        ([1.0, 1.0, 2.0], "not strictly increasing at index 1"),
        ([1.0, np.nan], "non-finite value at index 1"),
        ([], "empty"),
        ([-1.0, 1.0], "negative frequency"),
    ],
)
def test_bad_grids(grid, message):
    net = multi_loop_diagram()
    with pytest.raises(GridError, match=message):
        solve(net, grid, PARAMS, "r")


def test_missing_parameter_is_named():
    with pytest.raises(ParameterError, match="'tau'"):
        solve(multi_loop_diagram(), OMEGA, {k: v for k, v in PARAMS.items() if k != "tau"}, "r")


def test_a_tables_remembered_responses_are_shared_by_threads_safely():
    """The workbench's workers share a network: a table block's few remembered grids are read,
    added and evicted by several threads at once (before, the eviction raced: 'dictionary
    changed size during iteration' or a KeyError in some thread), with every answer the
    table's interpolation at the grid asked."""
    import sys
    import threading

    w = np.logspace(-1, 2, 50)
    block = TabulatedTransfer(FrequencyTable(w, 1 / (1j * w + 1)))
    grids = [np.logspace(-1, 2, 10 + k) for k in range(12)]
    errors: list[str] = []

    def ask(seed: int) -> None:
        try:
            for i in range(500):
                grid = grids[(seed * 5 + i) % len(grids)]
                assert np.array_equal(block.response(grid), block.table.interpolate(grid))
        except Exception as error:  # noqa: BLE001 - what any thread met is the test's verdict
            errors.append(repr(error))

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # threads switch often, as a loaded machine makes them
    try:
        threads = [threading.Thread(target=ask, args=(k,)) for k in range(6)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        sys.setswitchinterval(interval)
    assert errors == []

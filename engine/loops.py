"""Open-loop and closed-loop responses of a network, with sensitivities.

`LoopModel` is what the margin and measure routines read: the open loop GH on
a grid, and, when the network can be evaluated exactly, a function giving GH
and dGH/domega at any frequencies (used to refine crossings), plus the
characteristic frequencies of its blocks (used to place detection points).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import EngineError
from .network import Network, check_grid, solve

Evaluator = Callable[[NDArray[np.float64]], tuple[NDArray[np.complex128], NDArray[np.complex128]]]


@dataclass(frozen=True)
class Response:
    """A transfer response on a grid with its parameter sensitivities (F, P)."""

    omega: NDArray[np.float64]
    value: NDArray[np.complex128]
    parameters: tuple[str, ...]
    sensitivity: NDArray[np.complex128] | None


def open_loop(network: Network, break_at: str, omega: ArrayLike, params: Mapping[str, float],
              sensitivities: bool = True) -> Response:
    """GH(j omega) with the loop broken at ``break_at`` (1 + GH = 0 closes it)."""
    sol = solve(network, omega, params, break_at, break_at=break_at, sensitivities=sensitivities)
    k = network.signal(break_at)
    dgh = None if sol.dx is None else -sol.dx[:, k, :]
    return Response(sol.omega, -sol.x[:, k], sol.parameters, dgh)


def closed_loop(network: Network, source: str, target: str, omega: ArrayLike,
                params: Mapping[str, float], sensitivities: bool = True) -> Response:
    """Response of signal ``target`` to a unit injection at signal ``source``, all loops closed."""
    sol = solve(network, omega, params, source, sensitivities=sensitivities)
    j = network.signal(target)
    return Response(sol.omega, sol.x[:, j], sol.parameters,
                    None if sol.dx is None else sol.dx[:, j, :])


@dataclass(frozen=True)
class LoopModel:
    """An open loop for margin analysis.

    ``omega``/``gh``: the user's grid and the response on it.
    ``evaluate``: exact GH and dGH/domega at any frequencies (None for tables).
    ``corner_frequencies``/``dampings``: of every block pole and zero, to place
    detection points (empty when unknown).
    ``rational``: True when GH is a ratio of polynomials (no delay, no table):
    then crossings are sought over all frequencies, not just the grid's range.
    """

    omega: NDArray[np.float64]
    gh: NDArray[np.complex128]
    evaluate: Evaluator | None = None
    corner_frequencies: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    dampings: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    rational: bool = False
    dc_value: complex | None = None

    @staticmethod
    def from_table(omega: ArrayLike, gh: ArrayLike) -> LoopModel:
        """A tabulated open loop: margins use the report-000 grid rule."""
        w = check_grid(omega)
        return LoopModel(w, np.asarray(gh, dtype=complex))


def loop_model(network: Network, break_at: str, omega: ArrayLike, params: Mapping[str, float]) -> LoopModel:
    """The open loop at ``break_at`` with everything margins need."""
    w = check_grid(omega)
    k = network.signal(break_at)
    gh = open_loop(network, break_at, w, params, sensitivities=False).value
    if not network.exact:
        return LoopModel(w, gh)
    def evaluate(points: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        sol = solve(network, points, params, break_at, break_at=break_at,
                    sensitivities=False, d_omega=True, check=False)
        return -sol.x[:, k], -sol.dx_domega[:, k]

    corners, damps = _corners(network, params)
    dc = _dc_value(evaluate) if network.rational else None
    return LoopModel(w, gh, evaluate, corners, damps, network.rational, dc)


def _corners(network: Network, params: Mapping[str, float]) -> tuple[NDArray, NDArray]:
    """Corner frequencies and dampings of every rational entry's poles and zeros."""
    roots = []
    for entry in network.entries:
        if entry.transfer.rational_form:
            r = entry.transfer.rational(params)
            roots.extend(np.roots(r.num) if r.num.size > 1 else [])
            roots.extend(np.roots(r.den) if r.den.size > 1 else [])
    roots = np.asarray(roots, dtype=complex)
    roots = roots[np.isfinite(roots) & (np.abs(roots) > 0)]
    wn = np.abs(roots)
    return wn, np.abs(roots.real) / wn


def _dc_value(evaluate: Evaluator) -> complex | None:
    """GH(0) when finite (no integrator in the loop)."""
    try:
        with np.errstate(all="ignore"):
            value = evaluate(np.zeros(1))[0][0]
    except EngineError:
        return None
    return complex(value.real, 0.0) if np.isfinite(value) else None

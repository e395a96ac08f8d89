"""Open-loop and closed-loop responses of a network, with sensitivities.

`LoopModel` is what the margin and measure routines read: the open loop GH on
a grid, and, when the network can be evaluated exactly, a function giving GH
and dGH/domega at any frequencies (used to refine crossings), plus the
characteristic frequencies of its blocks (used to place detection points).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.derived import Derived, Form
from engine.errors import EngineError
from engine.loop.design import DesignLoop, design
from engine.loop.pole_zero import ZpkEvaluator
from engine.model.bilinear import real_frequency, refuse_above_nyquist
from engine.model.network import Network, check_grid, solve, warped

Evaluator = Callable[[NDArray[np.float64]], tuple[NDArray[np.complex128], NDArray[np.complex128]]]


@dataclass(frozen=True)
class Response:
    """A transfer response on a grid with its parameter sensitivities (F, P)."""

    omega: NDArray[np.float64]
    value: NDArray[np.complex128]
    parameters: tuple[str, ...]
    sensitivity: NDArray[np.complex128] | None


def crossing_motion(crossing: str, gh: complex, gh_x: NDArray, gh_w: complex) -> NDArray:
    """d omega / dx of a crossing of the open loop whose frequency moves with the parameters, from
    GH, dGH/dx and dGH/domega there: a phase crossover (``"G"``: arg GH stays put, Im ln GH) or a
    gain crossover (``"P"``: |GH| stays 1, Re ln GH); zero where the crossing's own slope is zero
    (the crossing's frequency is not a smooth function of x there)."""
    L_x, L_w = gh_x / gh, gh_w / gh
    slope, moved = (L_w.imag, L_x.imag) if crossing == "G" else (L_w.real, L_x.real)
    return -moved / slope if slope != 0 else np.zeros(np.shape(gh_x))


def open_loop(
    network: Network,
    break_at: str,
    omega: ArrayLike,
    params: Mapping[str, float],
    sensitivities: bool = True,
    check: bool = True,
) -> Response:
    """GH(j omega) with the loop broken at ``break_at`` (1 + GH = 0 closes it);
    ``check=False`` skips validating a grid and parameters the caller has validated."""
    sol = solve(
        network, omega, params, break_at, break_at=break_at, output=break_at, sensitivities=sensitivities, check=check
    )
    k = network.signal(break_at)
    dgh = None if sol.dx is None else -sol.dx[:, 0, :]
    return Response(sol.omega, -sol.x[:, k], sol.parameters, dgh)


def closed_loop(
    network: Network,
    source: str,
    target: str,
    omega: ArrayLike,
    params: Mapping[str, float],
    sensitivities: bool = True,
) -> Response:
    """Response of signal ``target`` to a unit injection at signal ``source``, all loops closed."""
    sol = solve(network, omega, params, source, output=target, sensitivities=sensitivities)
    j = network.signal(target)
    return Response(sol.omega, sol.x[:, j], sol.parameters, None if sol.dx is None else sol.dx[:, 0, :])


@dataclass(frozen=True)
class LoopSource:
    """The network a loop is broken from, where (``break_at``) and at which parameter values."""

    network: Network
    break_at: str
    params: Mapping[str, float]


class LoopModel:
    """An open loop for margin analysis.

    ``omega``/``gh``: the user's grid and the response on it (computed on
    first use for exact loops: margins of rational loops do not need it).
    ``evaluate``: exact GH and dGH/domega at any frequencies (None for tables).
    ``corner_frequencies``/``dampings``: of every block pole and zero, to place
    detection points (empty when unknown).
    ``rational``: True when GH is a ratio of polynomials (no delay, no table):
    then crossings are sought over all frequencies, not just the grid's range.
    ``dc_value``: GH(0) when finite and the loop can be evaluated exactly.
    ``delay``: the sum of the loop's delays (s; an upper bound of the phase
    rate a delay adds), ``axis_poles``: frequencies of block poles on the
    imaginary axis (GH may be infinite there), ``exact``: the network's own
    evaluator when ``evaluate`` is a faster form of it (`engine.loop.pole_zero`).
    ``source``: for a loop with tables, the network, break and values it was built from (to evaluate
    it off the table with each table's own fit in its place: `engine.margins.search.fitted_loop`).
    """

    def __init__(
        self,
        omega: NDArray[np.float64],
        gh: NDArray[np.complex128] | None = None,
        evaluate: Evaluator | None = None,
        corner_frequencies: NDArray | None = None,
        dampings: NDArray | None = None,
        rational: bool = False,
        dc_value: complex | None = None,
        delay: float = 0.0,
        axis_poles: NDArray | None = None,
        exact: Evaluator | None = None,
        source: LoopSource | None = None,
    ):
        if gh is None and evaluate is None:
            raise EngineError("a loop needs its response or an evaluator")
        self.omega = omega
        self._gh = None if gh is None else np.asarray(gh, dtype=complex)
        self.evaluate = evaluate
        self.corner_frequencies = np.zeros(0) if corner_frequencies is None else corner_frequencies
        self.dampings = np.zeros(0) if dampings is None else dampings
        self.rational = rational
        self.dc_value = dc_value
        self.delay = delay
        self.axis_poles = np.zeros(0) if axis_poles is None else axis_poles
        self.exact = exact if exact is not None else evaluate
        self.source = source
        self.derived = Derived()  # what is found on the loop (its margins), never stale: a loop is not changed

    def on_exact(self) -> LoopModel:
        """The same loop evaluated on the exact network (not the pole-zero form)."""
        return LoopModel(
            self.omega,
            self._gh,
            self.exact,
            self.corner_frequencies,
            self.dampings,
            self.rational,
            self.dc_value,
            self.delay,
            self.axis_poles,
            self.exact,
        )

    @property
    def gh(self) -> NDArray[np.complex128]:
        if self._gh is None:
            self._gh = self.evaluate(self.omega)[0]
        return self._gh


class SampledLoop(LoopModel):
    """A loop in z (sample time ``sample_time``) over rad/s below the Nyquist frequency pi/T:
    ``w_plane`` is the same loop over the w-plane frequency nu = tan(omega T/2), which the
    margin and peak searches read (`engine.margins.sampled`); this one evaluates it at
    nu(omega), with dGH/domega = dGH/dnu dnu/domega."""

    def __init__(self, w_plane: LoopModel, omega: NDArray[np.float64], sample_time: float):
        T = sample_time

        def in_omega(evaluate: Evaluator) -> Evaluator:
            def at(w: NDArray[np.float64]) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
                w = np.asarray(w, dtype=float)
                refuse_above_nyquist(w, T)
                nu, d_nu = warped(w, T)
                value, slope = evaluate(nu)
                return value, slope * d_nu

            return at

        super().__init__(
            omega,
            None,
            in_omega(w_plane.evaluate),
            real_frequency(w_plane.corner_frequencies, T),
            w_plane.dampings,
            False,  # searched through ``w_plane``, which covers every frequency up to pi/T
            w_plane.dc_value,
            axis_poles=real_frequency(w_plane.axis_poles, T),
            exact=in_omega(w_plane.exact),
        )
        self.w_plane = w_plane
        self.sample_time = sample_time

    def on_exact(self) -> LoopModel:
        return SampledLoop(self.w_plane.on_exact(), self.omega, self.sample_time)


LOOP_MODEL: Form[LoopModel] = Form("loop model")  # on a design: asked with the break and the grid


def loop_model(network: Network, break_at: str, omega: ArrayLike, params: Mapping[str, float]) -> LoopModel:
    """The open loop at ``break_at`` with everything margins need (rational loops
    are evaluated in pole-zero form when it matches the network: `engine.loop.pole_zero`;
    a sampled loop through its w-plane form: `SampledLoop`).  One object per design, break and
    grid, kept on the design: what is found on it (its margins: `engine.margins.search.margins`) is
    found once for the tableau and the plots."""
    w = check_grid(omega)
    if any(p not in params for p in network.parameters):  # the network's (or the design's) check names it
        return _loop_model(network, break_at, w, params)
    return design(network, params).derived.get(
        LOOP_MODEL,
        lambda: _loop_model(network, break_at, w.copy(), params),  # a copy: the caller may change its grid
        break_at,
        w.tobytes(),
    )


def _loop_model(network: Network, break_at: str, w: NDArray[np.float64], params: Mapping[str, float]) -> LoopModel:
    """`loop_model`, made."""
    if network.sample_time is not None:
        network.points(w)  # below the Nyquist frequency, or a GridError that says so
        nu, _ = warped(w, network.sample_time)
        return SampledLoop(loop_model(network.unsampled(), break_at, nu, params), w, network.sample_time)
    if not network.exact:
        gh = open_loop(network, break_at, w, params, sensitivities=False).value
        return LoopModel(w, gh, source=LoopSource(network, break_at, dict(params)))
    loop = design(network, params).loop(break_at)
    exact = loop.evaluator
    corners, damps, is_pole = exact.corners(params)
    evaluate = loop.pole_zero or exact
    own = _roots_no_block_has(loop, evaluate)
    if own is not None:
        corners, damps, is_pole = _with_loop_roots(corners, damps, is_pole, own)
    return LoopModel(
        w,
        None,
        evaluate,
        corners,
        damps,
        network.rational,
        _dc_value(
            evaluate if getattr(evaluate, "factored", False) else exact
        ),  # a factored form's roots at 0 are exact
        delay=network_delay(network, params),
        axis_poles=_axis_poles_of(evaluate, corners[is_pole & (damps <= 1e-9)]),
        exact=exact,
    )


def _axis_poles_of(evaluate: Evaluator, block_axis_poles: NDArray) -> NDArray:
    """The blocks' poles on the imaginary axis (frequencies) that GH may have: all of them, unless the
    loop's realized pole-zero form says which it has (an inner loop moves a block's poles: a plant's
    modes at 10 rad/s inside a closed loop are no pole of the loop seen at another break)."""
    if not isinstance(evaluate, ZpkEvaluator) or evaluate.factored or not block_axis_poles.size:
        return block_axis_poles
    poles = evaluate.poles  # (a pole at the origin is kept: a realized one is there only to rounding)
    if not poles.size:
        return block_axis_poles[block_axis_poles == 0]
    distance = np.min(np.abs(1j * block_axis_poles[:, None] - poles[None, :]), axis=1)
    return block_axis_poles[(block_axis_poles == 0) | (distance <= SAME_CORNER * block_axis_poles)]


SAME_CORNER = 1e-6  # relative frequency plus damping difference within which a loop root is a block's corner


def _roots_no_block_has(loop: DesignLoop, evaluate: Evaluator) -> NDArray | None:
    """The loop's own zeros and poles, where they may differ from its blocks': branches summed (a rate
    and an attitude channel, a plant's modes in parallel) make zeros no block has, an inner loop poles
    no block has.  From the realized pole-zero form, or, for a loop that is not one cascade and has
    none (a delay loop, a form off the network), from a realization of its rational part.  None for a
    cascade: its roots are its blocks'."""
    if isinstance(evaluate, ZpkEvaluator):
        return None if evaluate.factored else np.concatenate([evaluate.zeros, evaluate.poles])
    roots = None if loop.evaluator.cascade() is not None else loop.rational_roots
    return None if roots is None else np.concatenate(roots)


def _with_loop_roots(
    corners: NDArray, damps: NDArray, is_pole: NDArray, roots: NDArray
) -> tuple[NDArray, NDArray, NDArray]:
    """The blocks' corners and the loop's own light roots that no block has
    (`_roots_no_block_has`), lightly damped between the modes or beside them,
    which the detection grid must cluster around as around any light corner
    (counted as corners, not as block poles: ``axis_poles`` stay the blocks')."""
    from engine.margins.detection_grid import LIGHT_DAMPING  # (detection imports this module)

    roots = roots[np.isfinite(roots) & (np.abs(roots) > 0) & (roots.imag > 0)]  # one of each complex pair
    size, damping = np.abs(roots), np.abs(roots.real) / np.abs(roots)
    light = damping < LIGHT_DAMPING  # the grid clusters around light corners only (a far real zero
    size, damping = size[light], damping[light]  # would stretch its range by decades for nothing)
    known = np.zeros(size.size, dtype=bool)
    if corners.size:  # a block's own zero or pole (a cascade's part of the loop) is a corner already
        known = (
            np.min(np.abs(size[:, None] / corners[None, :] - 1) + np.abs(damping[:, None] - damps[None, :]), axis=1)
            <= SAME_CORNER
        )
    size, damping = size[~known], damping[~known]
    return (
        np.concatenate([corners, size]),
        np.concatenate([damps, damping]),
        np.concatenate([is_pole, np.zeros(size.size, dtype=bool)]),
    )


def network_delay(network: Network, params: Mapping[str, float]) -> float:
    """The sum of the network's delays (s)."""
    total = 0.0
    for e in network.entries:
        tau = getattr(e.transfer, "tau", None)
        if tau is not None:
            total += float(params[tau]) if isinstance(tau, str) else float(tau)
    return total


def _dc_value(evaluate: Evaluator) -> complex | None:
    """GH(0) when finite (no integrator in the loop)."""
    try:
        with np.errstate(all="ignore"):
            value = evaluate(np.zeros(1))[0][0]
    except EngineError:
        return None
    return complex(value.real, 0.0) if np.isfinite(value) else None

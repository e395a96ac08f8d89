"""The frequency-domain quadratic cost of report 001 (eq. 22-30) and its
analytic gradient, on the two-loop cascade of the report's Figure 2.

    x2 = G1 (d - u),  x1 = G2 x2,  u = Ga (H1 x1 + H2 x2)   (Ga includes K)
    OPEN = Ga (G1 H2 + G1G2 H1),  Gcl = G1G2 / (1 + OPEN)          (eq. 14)
    F(w) = |Gcl|^2 { (Vq + Vr)(|H1|^2 + |H2|^2) + Dq + Dr |H2/G2 + H1|^2 }   (eq. 23)

with Vq, Vr, Dq, Dr of eq. (24).  Integration is the listing's (CALFG):
the trapezoidal sum sum_i F(w_i)(w_{i+1} - w_{i-1}) over the data points
(w_0 = w_1, w_{N+1} = w_N), which is the printed F = 2 pi C; C of eq. (22)
is F / (2 pi).  Near a resonance, where |1 + OPEN|^2 < RSNAT at either end
of an interval, the interval is split into IN parts; tabulated plant data,
noise and disturbance weights are interpolated linearly there (as the
listing does), rational plants and the controllers are evaluated exactly.

Reading of the scan: CALFG's integration logic (labels 90-140) is garbled;
the rule above is its evident intent (and reproduces the printed sample).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..blocks import Transfer
from ..errors import EngineError


@dataclass(frozen=True)
class Weights:
    """Penalties (eq. 2-3), the averaging time T and the resonance rule."""

    q1: float = 1.0
    q2: float = 0.0
    r1: float = 0.0
    r2: float = 0.0
    rsnat: float = 0.5
    subdivisions: int = 3


@dataclass(frozen=True)
class Cascade:
    """The fixed data of the cascade on the integration grid (rad/s):
    G1, G1G2, Ga (with the transducer gain), the noise PSD Phi_v, and the
    disturbance term |d(jw)|^2 / T (or a disturbance PSD)."""

    omega: NDArray[np.float64]
    g1: NDArray[np.complex128]
    g1g2: NDArray[np.complex128]
    ga: NDArray[np.complex128]
    noise_psd: NDArray[np.float64]
    disturbance: NDArray[np.float64]
    exact: Callable[[NDArray], tuple[NDArray, NDArray, NDArray]] | None = None  # G1, G1G2, Ga anywhere

    def __post_init__(self) -> None:
        if self.omega.size < 3:
            raise EngineError("qcg: the integration grid needs at least 3 frequencies")
        if not np.all(np.diff(self.omega) > 0):
            raise EngineError("qcg: integration frequencies must increase")
        if np.any(self.g1 == 0) or np.any(self.g1g2 == 0):
            raise EngineError("qcg: G1 and G1G2 must not vanish on the grid (Vr and H2/G2 divide by them)")


def exponential_disturbance(omega: NDArray, amplitude: float, pole: float, averaging_time: float) -> NDArray:
    """|d(jw)|^2 / T for d(t) = A exp(-a t): A^2 / (T (w^2 + a^2))."""
    with np.errstate(all="ignore"):
        value = np.float64(amplitude) ** 2 / (averaging_time * (omega ** 2 + np.float64(pole) ** 2))
    if not np.all(np.isfinite(value)):
        raise EngineError("qcg: the disturbance term A^2 / (T (w^2 + a^2)) is not finite on the grid "
                          "(disturbance_amplitude, disturbance_pole, averaging_time)")
    return value


@dataclass(frozen=True)
class CostResult:
    """The listing's F and its parts (FDQ, FDR, FVQ, FVR), C = F/(2 pi),
    and the gradient dF/dp by parameter name (when asked)."""

    F: float
    parts: dict[str, float]
    gradient: dict[str, float] | None
    refined_intervals: int

    @property
    def C(self) -> float:
        return self.F / (2 * np.pi)


def _points(cascade: Cascade, open_at_grid: NDArray, weights: Weights):
    """The integration points: the grid, plus IN - 1 interior points in resonant intervals.
    Returns (omega, interval index i (point lies in (w_{i-1}, w_i]) or -1 for grid points, fraction)."""
    resonant = np.abs(1.0 + open_at_grid) ** 2 < weights.rsnat
    split = np.flatnonzero(resonant[1:] | resonant[:-1]) + 1   # interval (i-1, i) by its right end i
    n_in = weights.subdivisions
    if split.size == 0 or n_in < 2:
        return cascade.omega, np.arange(cascade.omega.size), np.ones(cascade.omega.size), 0
    fractions = np.arange(1, n_in) / n_in
    right = np.repeat(split, n_in - 1)
    frac = np.tile(fractions, split.size)
    w = cascade.omega
    inserted = w[right - 1] * (1 - frac) + w[right] * frac
    omega = np.concatenate([w, inserted])
    index = np.concatenate([np.arange(w.size), right])
    fraction = np.concatenate([np.ones(w.size), frac])
    order = np.argsort(omega, kind="stable")
    return omega[order], index[order], fraction[order], split.size


def _interpolated(values: NDArray, index: NDArray, fraction: NDArray) -> NDArray:
    """Linear interpolation between point index-1 and index (fraction 1 is the point itself)."""
    previous = values[np.maximum(index - 1, 0)]
    return previous * (1 - fraction) + values[index] * fraction


def quadratic_cost(cascade: Cascade, h1: Transfer | None, h2: Transfer | None, params: Mapping[str, float],
                   weights: Weights, gradient: bool = True, names: tuple[str, ...] = ()) -> CostResult:
    """F(b), its parts and (optionally) dF/dp for the parameters ``names``."""
    def evaluate(h: Transfer | None, w: NDArray):
        if h is None:
            return np.zeros(w.size, dtype=complex), {}
        dual = h.evaluate(1j * w, params)
        return np.broadcast_to(dual.value, w.shape).astype(complex), dual.grad

    H1g, _ = evaluate(h1, cascade.omega)
    H2g, _ = evaluate(h2, cascade.omega)
    open_grid = cascade.ga * (cascade.g1 * H2g + cascade.g1g2 * H1g)
    w, index, fraction, refined = _points(cascade, open_grid, weights)
    if cascade.exact is not None and refined:
        g1, g1g2, ga = cascade.exact(w)   # rational plant: exact values at the inserted points (beyond the listing)
    else:
        g1, g1g2, ga = (_interpolated(a, index, fraction) for a in (cascade.g1, cascade.g1g2, cascade.ga))
    gasq_grid = np.abs(cascade.ga) ** 2
    wg2 = cascade.omega ** 2
    # eq. (24) on the grid, interpolated linearly like the listing's DQ, VQ, VR, DR
    vq = _interpolated(cascade.noise_psd * (weights.q1 + wg2 * weights.q2) * gasq_grid, index, fraction)
    vr = _interpolated(cascade.noise_psd * (weights.r1 + wg2 * weights.r2) * gasq_grid / np.abs(cascade.g1g2) ** 2,
                       index, fraction)
    dq = _interpolated(cascade.disturbance * (weights.q1 + wg2 * weights.q2), index, fraction)
    dr = _interpolated(cascade.disturbance * (weights.r1 + wg2 * weights.r2) * gasq_grid, index, fraction)
    H1, grad1 = evaluate(h1, w)
    H2, grad2 = evaluate(h2, w)
    one_plus_open = 1.0 + ga * (g1 * H2 + g1g2 * H1)
    Y = g1g2 / one_plus_open
    M = g1 * H2 / g1g2 + H1                      # H2/G2 + H1
    hmag = np.abs(H1) ** 2 + np.abs(H2) ** 2
    y2 = np.abs(Y) ** 2
    padded = np.concatenate([w[:1], w, w[-1:]])
    dw = padded[2:] - padded[:-2]                # w_{i+1} - w_{i-1}
    parts = {"FDQ": float(np.sum(y2 * dq * dw)), "FDR": float(np.sum(y2 * dr * np.abs(M) ** 2 * dw)),
             "FVQ": float(np.sum(y2 * vq * hmag * dw)), "FVR": float(np.sum(y2 * vr * hmag * dw))}
    total = sum(parts.values())
    grad = None
    if gradient:
        Q = dq + dr * np.abs(M) ** 2 + (vq + vr) * hmag
        grad = {}
        for name in names:
            dH1 = np.broadcast_to(grad1.get(name, 0.0), w.shape)
            dH2 = np.broadcast_to(grad2.get(name, 0.0), w.shape)
            dY = -Y / one_plus_open * ga * (g1 * dH2 + g1g2 * dH1)
            dM = g1 * dH2 / g1g2 + dH1
            dQ = 2 * dr * np.real(np.conj(M) * dM) + 2 * (vq + vr) * np.real(np.conj(H1) * dH1 + np.conj(H2) * dH2)
            dF = 2 * np.real(np.conj(Y) * dY) * Q + y2 * dQ
            grad[name] = float(np.sum(dF * dw))
    return CostResult(total, parts, grad, refined)


def averaged_squares(cascade: Cascade, h1: Transfer | None, h2: Transfer | None, params: Mapping[str, float],
                     open_loop: Mapping[str, float] | None = None) -> dict[str, float]:
    """Averaged-square output, output rate, control, control rate (eq. 34-38),
    in the listing's convention (times 2 pi, as F) and normalized to the open loop
    for the output and its rate (the control is zero in open loop)."""
    out = {}
    for name, weights in (("x1", Weights(q1=1)), ("x1_rate", Weights(q1=0, q2=1)),
                          ("u", Weights(q1=0, r1=1)), ("u_rate", Weights(q1=0, r2=1))):
        out[name] = quadratic_cost(cascade, h1, h2, params, weights, gradient=False).F
    reference = open_loop if open_loop is not None else open_loop_squares(cascade)
    for name in ("x1", "x1_rate"):
        out[f"{name}_normalized"] = out[name] / reference[name] if reference[name] > 0 else float("nan")
    return out


def open_loop_squares(cascade: Cascade) -> dict[str, float]:
    """Averaged-square output and output rate with no controller."""
    return {name: quadratic_cost(cascade, None, None, {}, weights, gradient=False).F
            for name, weights in (("x1", Weights(q1=1)), ("x1_rate", Weights(q1=0, q2=1)))}


def frequency_response(cascade: Cascade, h1: Transfer | None, h2: Transfer | None, params: Mapping[str, float],
                       normalizing_gain: float) -> list[dict[str, float]]:
    """The listing's INST = 4 printout: Hz, |Gcl|/GN, angle Gcl (deg), OPEN."""
    w = cascade.omega
    H1 = h1.evaluate(1j * w, params).value if h1 is not None else 0.0 * w
    H2 = h2.evaluate(1j * w, params).value if h2 is not None else 0.0 * w
    open_ = cascade.ga * (cascade.g1 * H2 + cascade.g1g2 * H1)
    Y = cascade.g1g2 / (1 + open_)
    return [{"hz": float(wi / (2 * np.pi)), "magnitude": float(abs(y) / normalizing_gain),
             "phase_deg": float(np.degrees(np.angle(y))), "open_real": float(o.real), "open_imag": float(o.imag)}
            for wi, y, o in zip(w, Y, np.broadcast_to(open_, w.shape))]

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

Continuity (beyond the listing): the listing's split is all or nothing, so F
jumps where an interval's smaller |1 + OPEN|^2 crosses RSNAT (on the inlet
with q2 = 0, 0.14398 -> 0.14327 between b1 = 143.063 and 143.065).  Here an
interval counts (1 - w) of its plain trapezoid and w of its refined sum,
w = 1 below RSNAT (the listing), 0 from RSNAT (1 + BLEND) on, a smoothstep
between: F is continuous with its gradient (the analytic gradient includes
dw/db), and equals the listing's wherever no interval lies in that band.

Reading of the scan: CALFG's integration logic (labels 90-140) is garbled;
the rule above is its evident intent (and reproduces the printed sample).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.model.blocks import Transfer

BLEND = 0.05  # intervals with RSNAT <= min |1 + OPEN|^2 < RSNAT (1 + BLEND) are partly refined


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

    @cached_property
    def spectra(self) -> dict[str, NDArray]:
        """The weights of eq. (24) per unit penalty on the grid: disturbance (d, with |Ga|^2: dg)
        and noise (nq, over |G1G2|^2: nr) terms, each also times w^2 (suffix 2) for the rates."""
        gasq = np.abs(self.ga) ** 2
        base = {
            "d": self.disturbance,
            "dg": self.disturbance * gasq,
            "nq": self.noise_psd * gasq,
            "nr": self.noise_psd * gasq / np.abs(self.g1g2) ** 2,
        }
        return {
            name + suffix: value * factor
            for name, value in base.items()
            for suffix, factor in (("", 1.0), ("2", self.omega**2))
        }

    @cached_property
    def plain(self) -> Points:
        """The points of the sum with no interval refined: the grid, w_{i+1} - w_{i-1} each."""
        padded = np.concatenate([self.omega[:1], self.omega, self.omega[-1:]])
        none, empty = np.zeros(0, dtype=int), np.zeros(0)
        return Points(self.omega, none, empty, padded[2:] - padded[:-2], none, empty, empty)


def exponential_disturbance(omega: NDArray, amplitude: float, pole: float, averaging_time: float) -> NDArray:
    """|d(jw)|^2 / T for d(t) = A exp(-a t): A^2 / (T (w^2 + a^2))."""
    with np.errstate(all="ignore"):
        value = np.float64(amplitude) ** 2 / (averaging_time * (omega**2 + np.float64(pole) ** 2))
    if not np.all(np.isfinite(value)):
        raise EngineError(
            "qcg: the disturbance term A^2 / (T (w^2 + a^2)) is not finite on the grid "
            "(disturbance_amplitude, disturbance_pole, averaging_time)"
        )
    return value


@dataclass(frozen=True)
class CostResult:
    """The listing's F and its parts (FDQ, FDR, FVQ, FVR), C = F/(2 pi), the gradient
    dF/dp by parameter name (when asked), the number of (partly) refined intervals, and
    the unit-weight integrals ``squares`` (x1, x1_rate, u, u_rate: F with q1, q2, r1 or
    r2 alone equal to 1, the averaged squares of eq. 34-38) from the same evaluation."""

    F: float
    parts: dict[str, float]
    gradient: dict[str, float] | None
    refined_intervals: int
    squares: dict[str, float]

    @property
    def C(self) -> float:
        return self.F / (2 * np.pi)


class Points(NamedTuple):
    """The integration points: the grid, then IN - 1 points inside each refined interval
    (unsorted: the sum needs no order).  ``right``/``fraction`` place an inserted point
    between grid points right - 1 and right; ``coefficient`` is each point's weight in the
    sum; ``split`` (right ends), ``blend`` and ``slope`` (d blend / d m) describe the
    refined intervals."""

    omega: NDArray
    right: NDArray
    fraction: NDArray
    coefficient: NDArray
    split: NDArray
    blend: NDArray
    slope: NDArray


def blend_weight(m: NDArray, rsnat: float) -> tuple[NDArray, NDArray]:
    """How much of an interval's refined sum counts, given m, the smaller |1 + OPEN|^2 at
    its ends: 1 for m < RSNAT (the listing's split), 0 from RSNAT (1 + BLEND) on, a
    smoothstep between (continuous with its first derivative); and d weight / d m."""
    t = np.clip((m / rsnat - 1.0) / BLEND, 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t), -6.0 * t * (1.0 - t) / (BLEND * rsnat)


def _points(cascade: Cascade, r: NDArray, weights: Weights) -> Points:
    """The points and weights of the sum for |1 + OPEN|^2 = r on the grid."""
    n_in, omega = weights.subdivisions, cascade.omega
    if n_in < 2 or weights.rsnat <= 0:
        return cascade.plain
    blend, slope = blend_weight(np.minimum(r[1:], r[:-1]), weights.rsnat)
    chosen = np.flatnonzero(blend > 0)
    if chosen.size == 0:
        return cascade.plain
    length = np.diff(omega)
    split, blend, slope = chosen + 1, blend[chosen], slope[chosen]
    shares = np.ones(length.size)
    shares[chosen] -= blend * (1 - 1 / n_in)
    grid = np.zeros(omega.size)
    grid[:-1] += length * shares
    grid[1:] += length * shares
    frac = np.tile(np.arange(1, n_in) / n_in, split.size)
    right = np.repeat(split, n_in - 1)
    inserted = omega[right - 1] * (1 - frac) + omega[right] * frac
    inner = np.repeat(2 * length[chosen] * blend / n_in, n_in - 1)
    return Points(np.concatenate([omega, inserted]), right, frac, np.concatenate([grid, inner]), split, blend, slope)


def _at_points(values: NDArray, points: Points) -> NDArray:
    """Grid values, then linear interpolation at the inserted points (as the listing does)."""
    if points.right.size == 0:
        return values
    inserted = values[points.right - 1] * (1 - points.fraction) + values[points.right] * points.fraction
    return np.concatenate([values, inserted])


def _response(
    h: Transfer | None, w: NDArray, params: Mapping[str, float], gradient: bool
) -> tuple[NDArray, dict[str, NDArray]]:
    """A controller's value at jw and its parameter derivatives (zero without a controller)."""
    if h is None or w.size == 0:
        return np.zeros(w.size, dtype=complex), {}
    dual = h.evaluate(1j * w, params, with_grad=gradient)
    grad = {name: np.broadcast_to(g, w.shape) for name, g in dual.grad.items()} if gradient else {}
    return np.broadcast_to(dual.value, w.shape).astype(complex), grad


def _joined(grid: tuple[NDArray, dict], inserted: tuple[NDArray, dict]) -> tuple[NDArray, dict[str, NDArray]]:
    names = set(grid[1]) | set(inserted[1])
    zeros = (np.zeros(grid[0].size), np.zeros(inserted[0].size))
    return np.concatenate([grid[0], inserted[0]]), {
        n: np.concatenate([grid[1].get(n, zeros[0]), inserted[1].get(n, zeros[1])]) for n in names
    }


def _plant(cascade: Cascade, points: Points) -> tuple[NDArray, NDArray, NDArray]:
    """G1, G1G2, Ga at every point: exact for a rational plant, else interpolated."""
    arrays = (cascade.g1, cascade.g1g2, cascade.ga)
    inserted = points.omega[cascade.omega.size :]
    if cascade.exact is None or inserted.size == 0:
        return tuple(_at_points(a, points) for a in arrays)
    return tuple(np.concatenate([a, e]) for a, e in zip(arrays, cascade.exact(inserted)))


def quadratic_cost(
    cascade: Cascade,
    h1: Transfer | None,
    h2: Transfer | None,
    params: Mapping[str, float],
    weights: Weights,
    gradient: bool = True,
    names: tuple[str, ...] = (),
) -> CostResult:
    """F(b), its parts, the unit-weight integrals and (optionally) dF/dp for the parameters ``names``."""
    w = cascade.omega
    grid1, grid2 = _response(h1, w, params, gradient), _response(h2, w, params, gradient)
    open_grid = cascade.ga * (cascade.g1 * grid2[0] + cascade.g1g2 * grid1[0])
    points = _points(cascade, np.abs(1.0 + open_grid) ** 2, weights)
    inserted = points.omega[w.size :]
    H1, dH1 = _joined(grid1, _response(h1, inserted, params, gradient))
    H2, dH2 = _joined(grid2, _response(h2, inserted, params, gradient))
    g1, g1g2, ga = _plant(cascade, points)
    s = {name: _at_points(value, points) for name, value in cascade.spectra.items()}
    one_plus_open = 1.0 + ga * (g1 * H2 + g1g2 * H1)
    Y = g1g2 / one_plus_open
    M = g1 * H2 / g1g2 + H1  # H2/G2 + H1
    hmag, m2, y2, c = np.abs(H1) ** 2 + np.abs(H2) ** 2, np.abs(M) ** 2, np.abs(Y) ** 2, points.coefficient
    squares = {
        "x1": y2 * (s["d"] + s["nq"] * hmag),
        "x1_rate": y2 * (s["d2"] + s["nq2"] * hmag),
        "u": y2 * (s["dg"] * m2 + s["nr"] * hmag),
        "u_rate": y2 * (s["dg2"] * m2 + s["nr2"] * hmag),
    }
    q = weights
    dq, dr = q.q1 * s["d"] + q.q2 * s["d2"], q.r1 * s["dg"] + q.r2 * s["dg2"]
    vq, vr = q.q1 * s["nq"] + q.q2 * s["nq2"], q.r1 * s["nr"] + q.r2 * s["nr2"]
    parts = {
        "FDQ": float(y2 * dq @ c),
        "FDR": float(y2 * dr * m2 @ c),
        "FVQ": float(y2 * vq * hmag @ c),
        "FVR": float(y2 * vr * hmag @ c),
    }
    grad = None
    if gradient:
        Q = dq + dr * m2 + (vq + vr) * hmag
        blend = _blend_sensitivity(y2 * Q, points, np.abs(1.0 + open_grid) ** 2, weights.subdivisions)
        zero = np.zeros(w.size + inserted.size)
        grad = {}
        for name in names:
            d1, d2 = dH1.get(name, zero), dH2.get(name, zero)
            d_open = ga * (g1 * d2 + g1g2 * d1)
            dY = -Y / one_plus_open * d_open
            dM = g1 * d2 / g1g2 + d1
            dQ = 2 * dr * np.real(np.conj(M) * dM) + 2 * (vq + vr) * np.real(np.conj(H1) * d1 + np.conj(H2) * d2)
            dF = 2 * np.real(np.conj(Y) * dY) * Q + y2 * dQ
            d_r = 2 * np.real(np.conj(one_plus_open[: w.size]) * d_open[: w.size])  # d|1 + OPEN|^2 on the grid
            grad[name] = float(dF @ c + blend.weight @ d_r[blend.at])
    return CostResult(
        sum(parts.values()), parts, grad, int(points.split.size), {k: float(v @ c) for k, v in squares.items()}
    )


class BlendSensitivity(NamedTuple):
    """dF = weight @ d|1 + OPEN|^2[at]: how F moves through the blend weights."""

    weight: NDArray
    at: NDArray


def _blend_sensitivity(integrand: NDArray, points: Points, r: NDArray, n_in: int) -> BlendSensitivity:
    """F = plain sum + sum_i blend_i (refined_i - plain_i); blend_i depends on m_i = min(r_i-1, r_i)."""
    n = r.size
    right = points.split
    if right.size == 0:
        return BlendSensitivity(np.zeros(0), np.zeros(0, dtype=int))
    inner = integrand[n:].reshape(right.size, n_in - 1).sum(axis=1)
    length = points.omega[right] - points.omega[right - 1]
    gain = length * ((1 / n_in - 1) * (integrand[right - 1] + integrand[right]) + 2 / n_in * inner)
    at = np.where(r[right - 1] <= r[right], right - 1, right)
    return BlendSensitivity(points.slope * gain, at)


def normalized_squares(squares: Mapping[str, float], open_loop: Mapping[str, float]) -> dict[str, float]:
    """Averaged-square output, output rate, control, control rate (eq. 34-38) in the listing's
    convention (times 2 pi, as F), and the output and its rate over their open-loop values
    (the control is zero in open loop)."""
    out = dict(squares)
    for name in ("x1", "x1_rate"):
        out[f"{name}_normalized"] = out[name] / open_loop[name] if open_loop[name] > 0 else float("nan")
    return out


def open_loop_squares(cascade: Cascade) -> dict[str, float]:
    """Averaged-square output and output rate with no controller (one evaluation)."""
    squares = quadratic_cost(cascade, None, None, {}, Weights(), gradient=False).squares
    return {name: squares[name] for name in ("x1", "x1_rate")}


def frequency_response(
    cascade: Cascade, h1: Transfer | None, h2: Transfer | None, params: Mapping[str, float], normalizing_gain: float
) -> list[dict[str, float]]:
    """The listing's INST = 4 printout: Hz, |Gcl|/GN, angle Gcl (deg), OPEN."""
    w = cascade.omega
    H1 = h1.evaluate(1j * w, params).value if h1 is not None else 0.0 * w
    H2 = h2.evaluate(1j * w, params).value if h2 is not None else 0.0 * w
    open_ = cascade.ga * (cascade.g1 * H2 + cascade.g1g2 * H1)
    Y = cascade.g1g2 / (1 + open_)
    return [
        {
            "hz": float(wi / (2 * np.pi)),
            "magnitude": float(abs(y) / normalizing_gain),
            "phase_deg": float(np.degrees(np.angle(y))),
            "open_real": float(o.real),
            "open_imag": float(o.imag),
        }
        for wi, y, o in zip(w, Y, np.broadcast_to(open_, w.shape))
    ]

"""The structured singular value of an m x m complex matrix M for the diagonal structure
Delta = diag(delta_1, ..., delta_m) of complex scalars, bracketed at one frequency.

Upper bound (`upper`): inf over positive diagonal D of sigma_max(D M D^-1).  With D = e^X,
sigma_max(e^X M e^-X) is a convex function of the diagonal X (Sezginer and Overton 1990),
so a local minimum is the minimum: BFGS on it, the gradient sigma (|u_i|^2 - |v_i|^2) from
the top singular vectors u, v, from Osborne's balancing of |M| (or a warm start), and
Nelder and Mead's method after it where the top singular value is repeated (the function
is not smooth there).  For up to three scalar blocks the bound is mu itself (Doyle 1982);
for four and more it may exceed mu, and the caller says so.

Lower bound (`lower`): mu(M) = max over diagonal unitary Q of rho(M Q) (Doyle 1982), so any
Q gives rho(M Q) <= mu.  Started from Q = diag(v_i / u_i) of the scaled matrix's singular
vectors (the maximizer where sigma_max is simple at the optimal scaling), then searched by
Nelder and Mead (Brent for two loops) when that start falls short of the upper bound.  The
destabilizing perturbation is Delta = Q / lambda, lambda the largest eigenvalue of M Q:
det(I - M Delta) = 0 with every |delta_i| = 1 / rho(M Q)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

SCALE_BOUND = 30.0  # |log d| of a D-scale: e^30 = 1e13 (a scale beyond is a loop that does not interact)
PHASE_STARTS = 3  # random starts of the phase search after the singular vectors' phases
MATCHED = 1e-10  # the lower bound within this (relative) of the upper: no phase search
SWEEPS = 12  # Osborne sweeps of the batched start
DESCENT_STEPS = 12  # gradient steps of the batched improvement of scales (`descended`)


@dataclass(frozen=True)
class Bracket:
    """mu at one frequency: ``low`` <= mu <= ``high``; ``scales`` (log D, the last 0) attaining
    ``high``, ``delta`` (m complex, |delta_i| = 1/low) with det(I - M diag(delta)) = 0."""

    low: float
    high: float
    scales: NDArray[np.float64]
    delta: NDArray[np.complex128]


def scaled(m: NDArray, x: NDArray) -> NDArray[np.complex128]:
    """e^X M e^-X for log scales x (the last axis of x: one per loop; batches broadcast)."""
    d = np.exp(x)
    return d[..., :, None] * m / d[..., None, :]


def osborne(m: NDArray) -> NDArray[np.float64]:
    """Log scales balancing |M| (off-diagonal row sums equal to column sums), for a batch of
    matrices (points x m x m): a start, and a cheap upper bound, at many frequencies at once."""
    a = np.abs(m) * (1.0 - np.eye(m.shape[-1])) + 1e-300
    x = np.zeros(m.shape[:-1])
    for _ in range(SWEEPS):
        d = np.exp(x)
        b = a * d[..., :, None] / d[..., None, :]
        x = np.clip(x + 0.5 * (np.log(b.sum(axis=-2)) - np.log(b.sum(axis=-1))), -SCALE_BOUND, SCALE_BOUND)
    return x - x[..., -1:]


def _norm_and_gradient(free: NDArray, m: NDArray) -> tuple[float, NDArray]:
    u, s, vh = np.linalg.svd(scaled(m, np.append(free, 0.0)))
    return float(s[0]), (s[0] * (np.abs(u[:, 0]) ** 2 - np.abs(vh[0]) ** 2))[:-1]


def descended(m: NDArray, x: NDArray, steps: int = DESCENT_STEPS) -> tuple[NDArray, NDArray]:
    """(sigma_max(e^X M e^-X), X) after ``steps`` of gradient descent on the log scales of a batch of
    matrices (points x m x m) from ``x`` (points x m), each step halved where it does not lower the
    norm: a cheap improvement of many scales at once (`upper` optimizes one to the end)."""
    x = np.array(x, dtype=float)
    rate = np.ones(x.shape[0])

    def evaluate(at: NDArray) -> tuple[NDArray, NDArray]:
        u, s, vh = np.linalg.svd(scaled(m, at))
        return s[..., 0], np.abs(u[..., :, 0]) ** 2 - np.abs(vh[..., 0, :]) ** 2

    value, gradient = evaluate(x)
    for _ in range(steps):
        trial = np.clip(x - rate[:, None] * gradient, -SCALE_BOUND, SCALE_BOUND)
        trial_value, trial_gradient = evaluate(trial)
        better = trial_value < value
        x[better], value[better], gradient[better] = trial[better], trial_value[better], trial_gradient[better]
        rate = np.where(better, rate * 1.5, rate * 0.5)
    return value, x - x[..., -1:]


def upper(m: NDArray, start: NDArray | None = None) -> tuple[float, NDArray[np.float64]]:
    """(inf_D sigma_max(D M D^-1), its log scales x with x[-1] = 0) (module docstring)."""
    from scipy import optimize

    if m.shape[0] == 1:
        return float(abs(m[0, 0])), np.zeros(1)
    x0 = osborne(m) if start is None else np.asarray(start, dtype=float) - start[-1]
    found = optimize.minimize(
        _norm_and_gradient, x0[:-1], args=(m,), jac=True, method="BFGS", options={"gtol": 1e-13, "maxiter": 200}
    )
    free = np.clip(found.x, -SCALE_BOUND, SCALE_BOUND)
    s = np.linalg.svd(scaled(m, np.append(free, 0.0)), compute_uv=False)
    if s.size > 1 and s[1] > s[0] * (1.0 - 1e-6):  # a repeated top singular value: not smooth there
        polished = optimize.minimize(
            lambda f: _norm_and_gradient(np.clip(f, -SCALE_BOUND, SCALE_BOUND), m)[0],
            free,
            method="Nelder-Mead",
            options={"xatol": 1e-11, "fatol": 1e-16 * s[0], "maxiter": 2000},
        )
        free = np.clip(polished.x, -SCALE_BOUND, SCALE_BOUND) if polished.fun < s[0] else free
    x = np.append(free, 0.0)
    value = float(np.linalg.norm(scaled(m, x), 2))
    start_value = float(np.linalg.norm(scaled(m, x0), 2))
    return (value, x) if value <= start_value else (start_value, x0)


def radius(m: NDArray, phases: NDArray) -> tuple[float, complex]:
    """(rho(M Q), the eigenvalue attaining it) for Q = diag(e^{j phases})."""
    values = np.linalg.eigvals(m * np.exp(1j * phases)[None, :])
    k = int(np.argmax(np.abs(values)))
    return float(abs(values[k])), complex(values[k])


def vector_phases(m: NDArray, x: NDArray) -> NDArray[np.float64]:
    """angle(v_i / u_i) of the top singular vectors of e^X M e^-X (batches too), the last 0."""
    u, _, vh = np.linalg.svd(scaled(m, x))
    top_u, top_v = u[..., :, 0], vh[..., 0, :].conj()
    phases = np.angle(top_v * top_u.conj())
    return phases - phases[..., -1:]


def _search(m: NDArray, start: NDArray) -> NDArray[np.float64]:
    """Phases (the last 0) maximizing rho(M Q) locally from ``start``."""
    from scipy import optimize

    def f(free: NDArray) -> float:
        return -radius(m, np.append(free, 0.0))[0]

    if m.shape[0] == 2:
        found = optimize.minimize_scalar(lambda t: f(np.array([t])), bracket=(start[0] - 0.3, start[0] + 0.3))
        return np.array([float(found.x), 0.0])
    found = optimize.minimize(f, start[:-1], method="Nelder-Mead", options={"xatol": 1e-11, "maxiter": 3000})
    return np.append(found.x, 0.0)


def lower(m: NDArray, x: NDArray, high: float) -> tuple[float, NDArray[np.complex128]]:
    """(rho(M Q) at the best Q found, the destabilizing Delta = Q / lambda) (module docstring)."""
    size = m.shape[0]
    best = vector_phases(m, x) if size > 1 else np.zeros(1)
    value = radius(m, best)[0]
    if size > 1 and value < high * (1.0 - MATCHED):
        rng = np.random.default_rng(size)
        for start in [best] + [rng.uniform(-np.pi, np.pi, size) for _ in range(PHASE_STARTS)]:
            phases = _search(m, start - start[-1])
            found = radius(m, phases)[0]
            if found > value:
                value, best = found, phases
            if value >= high * (1.0 - MATCHED):
                break
    rho, eigenvalue = radius(m, best)
    if rho == 0:
        return 0.0, np.zeros(size, dtype=complex)
    return rho, np.exp(1j * best) / eigenvalue


def bracket(m: NDArray, start: NDArray | None = None) -> Bracket:
    """Both bounds of mu(M) (module docstring)."""
    high, x = upper(m, start)
    low, delta = lower(m, x, high)
    return Bracket(min(low, high), high, x, delta)

"""Independent references for the multi-loop tests and bench (issue 56): random square plants
built from a chosen stable closed loop, the plant's response from its matrices, the loop at
one break from the transfer matrix (not from a realization), and a reference bracket of the
multi-loop disk margin: a dense frequency grid refined about every light mode, mu's lower
bound rho(M Q) over a grid of phases there, the best points refined by scipy over (omega,
phases), and at the worst point the D-scale upper bound by scipy's Nelder-Mead."""

from __future__ import annotations

import numpy as np
from scipy import linalg, optimize


def random_plant(
    rng: np.random.Generator, order: int, loops: int, light: float = 0.4, feedthrough: bool = False, axis: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, B, C, D of a square plant whose unity-feedback closed loop is stable by construction:
    A_cl (real poles and pairs, a fraction ``light`` damped 0.003-0.05, in random coordinates) is
    chosen first and A = A_cl + B (I + D)^-1 C, so the open loop is often unstable; ``axis``:
    pairs of the plant's own poles put on the imaginary axis (as the spinning satellite's)."""
    blocks, k = [], 0
    while k < order:
        if order - k >= 2 and rng.random() < 0.6:
            w = 10 ** rng.uniform(-1, 2)
            z = 10 ** rng.uniform(-2.5, -1.3) if rng.random() < light else rng.uniform(0.2, 0.9)
            blocks.append(np.array([[-z * w, w * np.sqrt(1 - z * z)], [-w * np.sqrt(1 - z * z), -z * w]]))
            k += 2
        else:
            blocks.append(np.array([[-(10 ** rng.uniform(-1, 2))]]))
            k += 1
    t = np.eye(order) + 0.3 * rng.standard_normal((order, order)) / np.sqrt(order)
    a_cl = t @ linalg.block_diag(*blocks) @ np.linalg.inv(t)
    b, c = rng.standard_normal((order, loops)), rng.standard_normal((loops, order))
    d = 0.3 * rng.standard_normal((loops, loops)) if feedthrough else np.zeros((loops, loops))
    a = a_cl + b @ np.linalg.solve(np.eye(loops) + d, c)
    for _ in range(axis):  # an undamped pair of plant poles, kept where the closed loop stays stable
        for _ in range(50):
            trial = _with_axis_pair(a, b, c, 10 ** rng.uniform(-0.5, 1), rng)
            if closed_loop_abscissa(*trial, d) < 0:
                a, b, c = trial
                break
    return a, b, c, d


def closed_loop_abscissa(a, b, c, d) -> float:
    """The largest real part of the unity-feedback closed loop's poles."""
    return float(np.linalg.eigvals(a - b @ np.linalg.solve(np.eye(b.shape[1]) + d, c)).real.max())


def _with_axis_pair(a, b, c, w, rng):
    """The plant with two more states, an undamped pair at +-j w, in series at the first input."""
    n, m = a.shape[0], b.shape[1]
    a2 = np.zeros((n + 2, n + 2))
    a2[:n, :n], a2[n:, n:] = a, np.array([[0.0, w], [-w, 0.0]])
    b2 = np.vstack([b, 0.1 * rng.standard_normal((2, m))])
    c2 = np.hstack([c, 0.1 * rng.standard_normal((m, 2))])
    return a2, b2, c2


def response(a, b, c, d, omega) -> np.ndarray:
    """P(j omega): points x m x m, by a dense solve at each point."""
    n = a.shape[0]
    return np.array([c @ np.linalg.solve(1j * w * np.eye(n) - a, b) + d for w in np.atleast_1d(omega)])


def loop_from_matrix(p: np.ndarray, i: int) -> np.ndarray:
    """L_i = P_ii - P_io (I + P_oo)^-1 P_oi at each point: the loop at input i, others closed."""
    o = [k for k in range(p.shape[1]) if k != i]
    if not o:
        return p[:, i, i]
    closing = np.eye(len(o)) + p[:, o][:, :, o]
    return p[:, i, i] - np.einsum("pj,pj->p", p[:, i, o], np.linalg.solve(closing, p[:, o, i][:, :, None])[:, :, 0])


def sensitivity_response(a, b, c, d, omega, skew: float = 0.0) -> np.ndarray:
    """(I + P)^-1 + (skew - 1)/2 I at each point, from P(j omega)."""
    p = response(a, b, c, d, omega)
    m = p.shape[1]
    return np.linalg.inv(np.eye(m) + p) + 0.5 * (skew - 1.0) * np.eye(m)


PHASES = {2: 36, 3: 12, 4: 4}  # phases a loop of the dense grid's search (the last loop's is 0)


def _phase_grid(m: int, per_axis: int) -> np.ndarray:
    axes = [np.linspace(-np.pi, np.pi, per_axis, endpoint=False)] * (m - 1)
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.column_stack([g.ravel() for g in mesh] + [np.zeros(mesh[0].size)])


def coarse_lower(mats: np.ndarray) -> np.ndarray:
    """max over a grid of phases of rho(M Q), at each point (a lower bound of mu)."""
    m = mats.shape[1]
    q = np.exp(1j * _phase_grid(m, PHASES[m]))
    values = np.linalg.eigvals(mats[:, None, :, :] * q[None, :, None, :])
    return np.abs(values).max(axis=(1, 2))


def reference_lower(a, b, c, d, skew: float = 0.0, points: int = 1000) -> tuple[float, float]:
    """(max over omega of mu's lower bound, where): the dense grid, then the best three points
    refined by Nelder-Mead over (log omega, phases)."""
    poles = np.linalg.eigvals(a - b @ np.linalg.solve(np.eye(b.shape[1]) + d, c))
    sizes = np.abs(np.concatenate([poles, np.linalg.eigvals(a)]))
    sizes = sizes[sizes > 0]
    grid = [np.geomspace(sizes.min() / 100, sizes.max() * 100, points)]
    grid += [abs(p.imag) + abs(p.real) * np.linspace(-3, 3, 31) for p in poles]
    omega = np.unique(np.concatenate(grid))
    omega = omega[omega > 0]
    low = coarse_lower(sensitivity_response(a, b, c, d, omega, skew))
    best, where = 0.0, np.nan
    m = b.shape[1]
    for k in np.argsort(low)[::-1][:3]:

        def f(v):
            mat = sensitivity_response(a, b, c, d, [np.exp(v[0])], skew)[0]
            return -np.abs(np.linalg.eigvals(mat * np.exp(1j * np.append(v[1:], 0.0))[None, :])).max()

        start = [np.log(omega[k]), *np.zeros(m - 1)]
        phases0 = _phase_grid(m, PHASES[m])
        mat0 = sensitivity_response(a, b, c, d, [omega[k]], skew)[0]
        radii = np.abs(np.linalg.eigvals(mat0[None] * np.exp(1j * phases0)[:, None, :])).max(axis=1)
        start[1:] = phases0[np.argmax(radii)][:-1]
        found = optimize.minimize(f, start, method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-15})
        if -found.fun > best:
            best, where = -found.fun, float(np.exp(found.x[0]))
    return best, where


def reference_upper(mat: np.ndarray) -> float:
    """inf over D of sigma_max(D M D^-1) by Nelder-Mead on log D from several starts."""
    m = mat.shape[0]

    def f(x):
        dd = np.exp(np.append(x, 0.0))
        return np.linalg.norm(dd[:, None] * mat / dd[None, :], 2)

    best = np.inf
    for start in (np.zeros(m - 1), np.ones(m - 1), -np.ones(m - 1)):
        found = optimize.minimize(f, start, method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-15})
        best = min(best, found.fun)
    return best

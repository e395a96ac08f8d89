"""Closed-loop poles to full accuracy: the eigenvalues of the closed-loop
state matrix, polished on the network's characteristic equation.

Eigenvalues are as accurate as their conditioning allows, and digits go
where roots cluster near the origin (seen: 1e-7 to 50 % relative on
order-16 loops whose roots span 1e-3..1e2).  The characteristic polynomial
of an interconnection of blocks b_i = n_i/d_i is

    F(s) = prod_i d_i(s) * det(I - G(s))

(G(s)[row, col]: the blocks' transfer functions as `Network.entries` place
them), and both factors can be evaluated at complex s to rounding: every
block in its own factored form, the determinant of a small matrix.  Its
logarithmic derivative is F'/F = sum over the blocks' poles 1/(s - p) -
trace((I - G)^-1 G'), so Aberth's simultaneous iteration (each root's
Newton step deflated by the others) refines every eigenvalue at once and
never lets two converge to one root.  When it does not converge, or the
count of block poles is not the order of the realization, the eigenvalues
are kept as they are.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import NDArray

from .blocks import ExpressionTransfer
from .errors import EngineError
from .factored import pole_zero
from .network import Network

ITERATIONS = 60
DONE = 1e-14  # relative correction at which every root is converged
ACCEPT = 1e-9  # ... at which the rounding floor stops the iteration, accepted (the error is ~ its cube)


def block_poles(network: Network, params: Mapping[str, float]) -> NDArray[np.complex128]:
    """Every block's own poles, from its factored form (exact to rounding)."""
    out = [np.zeros(0, dtype=complex)]
    for e in network.entries:
        if isinstance(e.transfer, ExpressionTransfer):
            out.append(pole_zero(e.transfer.expression, params).poles)
        else:
            den = e.transfer.rational(params).den
            out.append(np.roots(den) if den.size > 1 else np.zeros(0))
    return np.concatenate([np.asarray(p, dtype=complex) for p in out])


def log_derivative(network: Network, params: Mapping[str, float],
                   poles: NDArray) -> Callable[[NDArray], NDArray]:
    """s -> F'(s)/F(s) for the characteristic polynomial F of the module docstring."""
    n = len(network.signals)
    compiled = [(e.row, e.col, e.transfer.compile(params)) for e in network.entries]

    def ratio(s: NDArray[np.complex128]) -> NDArray[np.complex128]:
        G = np.zeros((s.size, n, n), dtype=complex)
        dG = np.zeros_like(G)
        for row, col, fun in compiled:
            value, slope = fun(s)
            G[:, row, col] += value
            dG[:, row, col] += slope
        M = np.eye(n)[None, :, :] - G
        return _block_terms(s, poles) - _traces(M, dG)

    return ratio


def _block_terms(s: NDArray, poles: NDArray) -> NDArray:
    return np.sum(1.0 / (s[:, None] - poles[None, :]), axis=1)


def _traces(M: NDArray, dG: NDArray) -> NDArray[np.complex128]:
    """trace(M^-1 dG) per point; infinite where M is singular (the point is a
    root of det(I - G): its Newton step is 0)."""
    try:
        return np.trace(np.linalg.solve(M, dG), axis1=1, axis2=2)
    except np.linalg.LinAlgError:
        out = np.empty(M.shape[0], dtype=complex)
        for k in range(M.shape[0]):
            try:
                out[k] = np.trace(np.linalg.solve(M[k], dG[k]))
            except np.linalg.LinAlgError:
                out[k] = np.inf
        return out




def polish(network: Network, params: Mapping[str, float], eigenvalues: NDArray[np.complex128]) -> NDArray:
    """The eigenvalues refined by Aberth's iteration on F (or as given, see the module docstring)."""
    start = np.asarray(eigenvalues, dtype=complex)
    try:
        poles = block_poles(network, params)
    except EngineError:  # a block without a usable rational form: nothing to polish against
        return start
    if start.size == 0 or poles.size != start.size:
        return start
    ratio = log_derivative(network, params, poles)
    z = start.copy()
    active = np.ones(z.size, dtype=bool)
    with np.errstate(all="ignore"):
        for _ in range(ITERATIONS):
            newton = 1.0 / ratio(z)
            others = 1.0 / (z[:, None] - z[None, :])
            np.fill_diagonal(others, 0.0)
            step = newton / (1.0 - newton * np.sum(others, axis=1))
            finite = np.isfinite(step)  # on a block pole or a root exactly: that root stays
            step = np.where(finite & active, step, 0.0)
            z = z - step
            relative = np.abs(step) / np.maximum(np.abs(z), 1e-300)
            active &= finite & (relative > DONE)
            if not active.any():
                break
    if np.any(relative > ACCEPT) or not np.all(np.isfinite(z)):
        return start
    return _real_where_real(z)


def _real_where_real(z: NDArray) -> NDArray:
    """Roots whose imaginary part is rounding noise, made real."""
    return np.where(np.abs(z.imag) <= 1e-13 * np.abs(z), z.real + 0j, z)

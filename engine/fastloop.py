"""A fast evaluator of one open loop GH(j omega) and dGH/domega for fixed
parameters, for the many small evaluations of margin refinement.

Two reductions make it fast without changing the arithmetic's accuracy:
* every block that folds to a polynomial ratio of degree <= 2 is evaluated
  with all the others in one batch (Horner's rule on a stack of coefficients);
* chains of signals with one producer and one consumer collapse into one
  edge whose gain is the product of its members (derivative by the product
  rule, accumulated member by member: no division, so zeros on the grid are fine).
The reduced graph is then solved like the full network (`sparse_solve`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from .blocks import ExpressionTransfer
from .errors import InterconnectionError
from .network import Network, schedule_edges, sparse_solve

FOLD_WIDTH = 3  # coefficients of a degree-2 polynomial


class LoopEvaluator:
    """GH and dGH/domega of ``network`` broken at ``break_at`` (exact networks only)."""

    def __init__(self, network: Network, break_at: str, params: Mapping[str, float]):
        self.network = network
        self.k = network.signal(break_at)
        self.entries = network.entries
        self._prepare_batch(params)
        self._reduce()

    def _prepare_batch(self, params: Mapping[str, float]) -> None:
        batch, num, den, self.single = [], [], [], {}
        for number, e in enumerate(self.entries):
            folded = e.transfer.expression.folded(params) if isinstance(e.transfer, ExpressionTransfer) else None
            if folded is None:
                self.single[number] = e.transfer.compile(params)
                continue
            batch.append(number)
            num.append(np.pad(folded.num, (FOLD_WIDTH - folded.num.size, 0)))
            den.append(np.pad(folded.den, (FOLD_WIDTH - folded.den.size, 0)))
        self.batch = np.array(batch, dtype=int)
        self.num, self.den = np.array(num).reshape(-1, FOLD_WIDTH), np.array(den).reshape(-1, FOLD_WIDTH)

    def corners(self, params: Mapping[str, float]) -> tuple[NDArray, NDArray]:
        """Natural frequencies and dampings of every block's poles and zeros."""
        roots = [_quadratic_roots(self.num), _quadratic_roots(self.den)]
        for number in self.single:
            transfer = self.entries[number].transfer
            if transfer.rational_form:
                r = transfer.rational(params)
                roots += [np.roots(r.num) if r.num.size > 1 else [], np.roots(r.den) if r.den.size > 1 else []]
        roots = np.concatenate([np.asarray(r, dtype=complex).ravel() for r in roots])
        roots = roots[np.isfinite(roots) & (np.abs(roots) > 0)]
        return np.abs(roots), np.abs(roots.real) / np.abs(roots)

    def _reduce(self) -> None:
        """Collapse single-in, single-out signals (not the break point) into chains."""
        n, k = len(self.network.signals), self.k
        source = n  # the injection replaces every use of x_k
        edges = [[e.row, source if e.col == k else e.col, [number]] for number, e in enumerate(self.entries)]
        while True:
            into = {i: [ed for ed in edges if ed[0] == i] for i in range(n)}
            out_of = {i: [ed for ed in edges if ed[1] == i] for i in range(n)}
            merge = next((i for i in range(n) if i != k and len(into[i]) == 1 and len(out_of[i]) == 1
                          and into[i][0] is not out_of[i][0]), None)
            if merge is None:
                break
            first, second = into[merge][0], out_of[merge][0]
            edges.remove(first)
            second[1], second[2] = first[1], first[2] + second[2]
        self.chains = [ed[2] for ed in edges]
        self.schedule = schedule_edges(n + 1, [(ed[0], ed[1], c) for c, ed in enumerate(edges)])
        self.size = n + 1

    def _blocks(self, x: NDArray) -> tuple[NDArray, NDArray]:
        values = np.empty((len(self.entries), x.size), dtype=complex)
        slopes = np.empty_like(values)
        if self.batch.size:
            n = d = np.zeros((self.batch.size, x.size), dtype=complex)
            dn = dd = np.zeros_like(n)
            for c in range(FOLD_WIDTH):  # Horner with derivative
                dn, n = dn * x + n, n * x + self.num[:, c:c + 1]
                dd, d = dd * x + d, d * x + self.den[:, c:c + 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                v = n / d
                values[self.batch], slopes[self.batch] = v, (dn - v * dd) / d
        for number, fun in self.single.items():
            values[number], slopes[number] = fun(x)
        bad = ~np.isfinite(values)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            e = self.entries[row]
            raise InterconnectionError(f"{e.label} ({e.transfer.text}) is not finite at "
                                       f"{abs(x[col]):.6g} rad/s (a pole on the grid?)")
        return values, slopes

    def __call__(self, omega: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """GH(j omega) and dGH/domega."""
        x = 1j * np.asarray(omega, dtype=float)
        values, slopes = self._blocks(x)
        gains, dgains = [], []
        for chain in self.chains:
            g, dg = values[chain[0]], slopes[chain[0]]
            for number in chain[1:]:
                dg, g = dg * values[number] + g * slopes[number], g * values[number]
            gains.append(g)
            dgains.append(dg)
        F = x.size
        rhs = np.zeros((self.size, 1, F), dtype=complex)
        rhs[-1, 0] = 1.0
        sol = sparse_solve(self.schedule, gains, rhs, np.asarray(omega, dtype=float))[:, 0, :]
        R = np.zeros((self.size, 1, F), dtype=complex)
        for (target, pairs) in enumerate(self.schedule.feeds):
            for src, c in pairs:
                R[target, 0] += 1j * dgains[c] * sol[src]
        dsol = sparse_solve(self.schedule, gains, R, np.asarray(omega, dtype=float))[:, 0, :]
        return -sol[self.k], -dsol[self.k]


def _quadratic_roots(c: NDArray) -> NDArray[np.complex128]:
    """Roots of each row a x^2 + b x + c (rows of degree 1 or 0 give fewer)."""
    if c.size == 0:
        return np.zeros(0, dtype=complex)
    a, b, k = c[:, 0].astype(complex), c[:, 1].astype(complex), c[:, 2].astype(complex)
    quad = a != 0
    root = np.sqrt(b[quad] ** 2 - 4 * a[quad] * k[quad])
    # the stable form: q = -(b + sign(b) sqrt(disc))/2, roots q/a and k/q
    sign = np.where((np.conj(b[quad]) * root).real >= 0, 1.0, -1.0)
    q = -0.5 * (b[quad] + sign * root)
    with np.errstate(divide="ignore", invalid="ignore"):
        pair = np.concatenate([q / a[quad], np.where(q != 0, k[quad] / q, 0)])
    linear = ~quad & (b != 0)
    return np.concatenate([pair, -k[linear] / b[linear]])

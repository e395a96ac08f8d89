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

from engine.errors import InterconnectionError
from engine.model.blocks import ExpressionTransfer, block_pole_zero
from engine.model.network import Network, schedule_edges, sparse_solve, warped

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
        batch, self.single = [], {}
        self.num, self.den = np.zeros((len(self.entries), FOLD_WIDTH)), np.zeros((len(self.entries), FOLD_WIDTH))
        for number, e in enumerate(self.entries):
            folded = e.transfer.expression.folded(params) if isinstance(e.transfer, ExpressionTransfer) else None
            if folded is None:
                self.single[number] = e.transfer.compile(params)
                continue
            k = len(batch)
            self.num[k, FOLD_WIDTH - folded.num.size :] = folded.num
            self.den[k, FOLD_WIDTH - folded.den.size :] = folded.den
            batch.append(number)
        self.batch = np.array(batch, dtype=int)
        self.num, self.den = self.num[: len(batch)], self.den[: len(batch)]

    def corners(self, params: Mapping[str, float]) -> tuple[NDArray, NDArray, NDArray]:
        """Natural frequencies and dampings of every block's poles and zeros,
        and which of them are poles."""
        zeros, poles = [_quadratic_roots(self.num)], [_quadratic_roots(self.den)]
        for number in self.single:
            transfer = self.entries[number].transfer
            if transfer.rational_form:  # factor by factor, or from a realization: no expansion overflows
                form = block_pole_zero(transfer, params)
                zeros.append(form.zeros)
                poles.append(form.poles)
        zeros = np.concatenate([np.asarray(r, dtype=complex).ravel() for r in zeros])
        poles = np.concatenate([np.asarray(r, dtype=complex).ravel() for r in poles])
        roots = np.concatenate([zeros, poles])
        is_pole = np.concatenate([np.zeros(zeros.size, dtype=bool), np.ones(poles.size, dtype=bool)])
        keep = np.isfinite(roots) & (np.abs(roots) > 0)
        roots, is_pole = roots[keep], is_pole[keep]
        return np.abs(roots), np.abs(roots.real) / np.abs(roots), is_pole

    def _reduce(self) -> None:
        """Collapse single-in, single-out signals (not the break point) into chains."""
        n, k = len(self.network.signals), self.k
        source = n  # the injection replaces every use of x_k
        edges = {number: [e.row, source if e.col == k else e.col, [number]] for number, e in enumerate(self.entries)}
        into: list[set[int]] = [set() for _ in range(n + 1)]
        out_of: list[set[int]] = [set() for _ in range(n + 1)]
        for number, (target, src, _) in edges.items():
            into[target].add(number)
            out_of[src].add(number)
        for signal in range(n):
            if signal == k or len(into[signal]) != 1 or len(out_of[signal]) != 1:
                continue
            (first,), (second,) = into[signal], out_of[signal]
            if first == second:
                continue  # a self-loop stays
            upstream = edges[first][1]
            edges[second][1] = upstream
            edges[second][2] = edges[first][2] + edges[second][2]
            out_of[upstream].discard(first)
            out_of[upstream].add(second)
            into[signal].clear()
            out_of[signal].clear()
            del edges[first]
        kept = list(edges.values())
        live = sorted({k, source} | {ed[0] for ed in kept} | {ed[1] for ed in kept})
        compact = {signal: i for i, signal in enumerate(live)}
        self.chains = [ed[2] for ed in kept]
        self.groups = _chain_groups(self.chains)
        self.schedule = schedule_edges(len(live), [(compact[ed[0]], compact[ed[1]], c) for c, ed in enumerate(kept)])
        self.size, self.out, self.source = len(live), compact[k], compact[source]

    def cascade(self) -> list[int] | None:
        """The entries of the one chain that carries the injection back to the
        break when the loop is a single cascade (then GH = -their product);
        None when other paths or inner loops carry it."""
        reached, frontier, carrying = {self.source}, [self.source], []
        while frontier:
            signal = frontier.pop()
            for target, feeds in enumerate(self.schedule.feeds):
                for src, chain in feeds:
                    if src == signal:
                        carrying.append((target, chain))
                        if target not in reached:
                            reached.add(target)
                            frontier.append(target)
        if len(carrying) != 1 or carrying[0][0] != self.out:
            return None
        return [int(number) for number in self.chains[carrying[0][1]]]

    def _blocks(self, omega: NDArray) -> tuple[NDArray, NDArray]:
        """Every block's value and d/dx at x = j omega."""
        x = 1j * omega
        values = np.empty((len(self.entries), omega.size), dtype=complex)
        slopes = np.empty_like(values)
        if self.batch.size:
            values[self.batch], slopes[self.batch] = _quadratic_ratios(self.num, self.den, omega)
        with np.errstate(all="ignore"):  # a value out of range is reported below, not warned about
            for number, fun in self.single.items():
                values[number], slopes[number] = fun(x)
        bad = ~np.isfinite(values)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            e = self.entries[row]
            raise InterconnectionError(
                f"{e.label} ({e.transfer.text}) is not finite at {omega[col]:.6g} rad/s (a pole on the grid?)"
            )
        return values, slopes

    def __call__(self, omega: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """GH(j omega) and dGH/domega; for a sampled loop (`Network.sampled`), GH at w = j tan(omega T/2)."""
        omega = np.asarray(omega, dtype=float)
        T = self.network.sample_time
        if T is None:
            return self._at(omega)
        nu, d_nu = warped(omega, T)
        value, slope = self._at(nu)
        return value, slope * d_nu

    def _at(self, omega: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """GH(j omega) and dGH/domega of the loop read as one in s (or w, over nu)."""
        values, slopes = self._blocks(omega)
        gains, dgains = self._chain_gains(values, slopes)
        F = omega.size
        rhs = np.zeros((self.size, 1, F), dtype=complex)
        rhs[self.source, 0] = 1.0
        sol = sparse_solve(self.schedule, gains, rhs, omega)[:, 0, :]
        R = np.zeros((self.size, 1, F), dtype=complex)
        for target, pairs in enumerate(self.schedule.feeds):
            for src, c in pairs:
                R[target, 0] += 1j * dgains[c] * sol[src]
        dsol = sparse_solve(self.schedule, gains, R, omega)[:, 0, :]
        return -sol[self.out], -dsol[self.out]

    def _chain_gains(self, values: NDArray, slopes: NDArray) -> tuple[NDArray, NDArray]:
        """Every chain's gain and d/dx (rows in chain order), equally long chains together."""
        gains = np.empty((len(self.chains), values.shape[1]), dtype=complex)
        dgains = np.empty_like(gains)
        for rows, members in self.groups:
            if members.shape[1] == 1:
                gains[rows], dgains[rows] = values[members[:, 0]], slopes[members[:, 0]]
                continue
            v, d = values[members], slopes[members]
            nonzero = np.all(v != 0, axis=(1, 2))
            g = np.prod(v[nonzero], axis=1)
            gains[rows[nonzero]], dgains[rows[nonzero]] = g, g * np.sum(d[nonzero] / v[nonzero], axis=1)
            for row in np.flatnonzero(~nonzero).tolist():  # a zero on the grid: no division
                chain = members[row]
                gains[rows[row]], dgains[rows[row]] = _chain_product(values[chain], slopes[chain])
        return gains, dgains


def _chain_groups(chains: list[list[int]]) -> list[tuple[NDArray, NDArray]]:
    """(chain numbers, their members as rows) per chain length."""
    lengths = sorted({len(c) for c in chains})
    return [
        (
            np.array([k for k, c in enumerate(chains) if len(c) == n], dtype=int),
            np.array([c for c in chains if len(c) == n], dtype=int),
        )
        for n in lengths
    ]


def _quadratic_ratios(num: NDArray, den: NDArray, omega: NDArray) -> tuple[NDArray, NDArray]:
    """(a x^2 + b x + c)/(d x^2 + e x + f) and its d/dx at x = j omega, row by row,
    in real arithmetic: at x = j omega a quadratic is (c - a omega^2) + j b omega."""
    w, w2 = omega[None, :], (omega * omega)[None, :]

    def quad(c: NDArray) -> tuple[NDArray, NDArray]:
        value = (c[:, 2:3] - c[:, 0:1] * w2) + 1j * (c[:, 1:2] * w)
        slope = c[:, 1:2] + 1j * (2.0 * c[:, 0:1] * w)
        return value, slope

    (n, dn), (d, dd) = quad(num), quad(den)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = 1.0 / d
        value = n * inverse
        return value, (dn - value * dd) * inverse


def _chain_product(values: NDArray, slopes: NDArray) -> tuple[NDArray, NDArray]:
    """Product of the rows and its derivative (product rule)."""
    g = np.prod(values, axis=0)
    if values.shape[0] == 1:
        return g, slopes[0]
    if np.all(values != 0):
        return g, g * np.sum(slopes / values, axis=0)
    dg = slopes[0]
    gi = values[0]
    for v, s in zip(values[1:], slopes[1:]):  # a zero on the grid: no division
        dg, gi = dg * v + gi * s, gi * v
    return g, dg


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

"""Interconnections: block diagrams and COEBRA's matrix format, compiled to one
form, solved for all frequencies at once with parameter sensitivities.

The compiled form is a set of signals x_1..x_n in which equation i defines
signal i:  x_i = sum_j G_ij(s) x_j  (+ an injection).  Exogenous inputs have
no terms.  At every frequency M(s) = I - G(s) and M x = b is solved as one
batched linear solve; sensitivities come from the same matrices:
dx/dp = M^-1 (dG/dp) x.

Breaking the loop at signal k replaces every *use* of x_k (column k of G) by
an injected unit signal v; the open loop is GH = -x_k (returned), so that the
closed-loop characteristic equation at that point is 1 + GH = 0.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .blocks import ExpressionTransfer, Transfer
from .errors import EngineError, GridError, InterconnectionError, ParameterError


@dataclass(frozen=True)
class Block:
    """output = transfer(s) * input."""

    name: str
    input: str
    output: str
    transfer: Transfer


@dataclass(frozen=True)
class Junction:
    """output = sum of sign * signal over ``terms`` (sign +1 or -1)."""

    name: str
    output: str
    terms: tuple[tuple[float, str], ...]


@dataclass(frozen=True)
class Entry:
    """x_row += transfer * x_col, labelled by where it came from."""

    row: int
    col: int
    transfer: Transfer
    label: str


@dataclass(frozen=True)
class Network:
    """The compiled interconnection (see module docstring)."""

    signals: tuple[str, ...]
    inputs: tuple[str, ...]
    entries: tuple[Entry, ...]
    variable: str = "s"
    index: dict[str, int] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        self.index.update({name: i for i, name in enumerate(self.signals)})

    @property
    def parameters(self) -> tuple[str, ...]:
        return tuple(sorted({p for e in self.entries for p in e.transfer.parameters}))

    @property
    def exact(self) -> bool:
        """True when every entry can be evaluated at any frequency exactly."""
        return all(e.transfer.exact for e in self.entries)

    @property
    def rational(self) -> bool:
        return all(e.transfer.rational_form for e in self.entries)

    def signal(self, name: str) -> int:
        if name not in self.index:
            raise InterconnectionError(f"unknown signal {name!r}; signals are {', '.join(self.signals)}")
        return self.index[name]


def block_diagram(blocks: Sequence[Block], junctions: Sequence[Junction] = (),
                  inputs: Sequence[str] = (), variable: str = "s") -> Network:
    """Compile a block diagram; every signal read must be produced or a declared input."""
    producers: dict[str, str] = {name: f"input {name!r}" for name in inputs}
    for item in list(blocks) + list(junctions):
        kind = "block" if isinstance(item, Block) else "junction"
        if item.output in producers:
            raise InterconnectionError(f"signal {item.output!r} is produced by both "
                                       f"{producers[item.output]} and {kind} {item.name!r}")
        producers[item.output] = f"{kind} {item.name!r}"
    signals = tuple(producers)
    index = {name: i for i, name in enumerate(signals)}

    def read(signal: str, who: str) -> int:
        if signal not in index:
            raise InterconnectionError(f"{who} reads signal {signal!r}, which no block or junction "
                                       "produces and which is not a declared input")
        return index[signal]

    entries = [Entry(index[b.output], read(b.input, f"block {b.name!r}"), b.transfer, b.name)
               for b in blocks]
    for j in junctions:
        for sign, signal in j.terms:
            if sign not in (1, -1, 1.0, -1.0):
                raise InterconnectionError(f"junction {j.name!r}: sign must be +1 or -1, not {sign!r}")
            col = read(signal, f"junction {j.name!r}")
            entries.append(Entry(index[j.output], col, ExpressionTransfer(repr(float(sign)), variable), j.name))
    return Network(signals, tuple(inputs), tuple(entries), variable)


def matrix_format(signals: Sequence[str], entries: Mapping[tuple[int, int], str],
                  forcing_row: int, forcing: str = "1", input_name: str = "theta",
                  variable: str = "s") -> Network:
    """COEBRA's A(s) x = B theta with one forcing input (row and column indices from 1).

    Row i defines signal i: a_ii x_i + sum_j a_ij x_j = b_i theta, so
    x_i = sum_j (-a_ij/a_ii) x_j + (b_i/a_ii) theta.  Entries are rational
    expressions of any order.
    """
    n = len(signals)
    if len(set(signals)) != n or input_name in signals:
        raise InterconnectionError("matrix format: signal names must be distinct and differ from the input")
    for (i, j) in entries:
        if not (1 <= i <= n and 1 <= j <= n):
            raise InterconnectionError(f"matrix format: entry a[{i},{j}] is outside the {n}x{n} matrix")
    if not 1 <= forcing_row <= n:
        raise InterconnectionError(f"matrix format: forcing row {forcing_row} is outside 1..{n}")
    missing = [i for i in range(1, n + 1) if (i, i) not in entries]
    if missing:
        raise InterconnectionError(f"matrix format: row {missing[0]} has no diagonal entry "
                                   f"a[{missing[0]},{missing[0]}]; row i must define signal i")
    all_signals = tuple(signals) + (input_name,)
    compiled = []
    for (i, j), text in sorted(entries.items()):
        if i == j:
            continue
        diag = entries[(i, i)]
        compiled.append(Entry(i - 1, j - 1, ExpressionTransfer(f"-({text})/({diag})", variable), f"a[{i},{j}]"))
    diag = entries[(forcing_row, forcing_row)]
    compiled.append(Entry(forcing_row - 1, n, ExpressionTransfer(f"({forcing})/({diag})", variable),
                          f"b[{forcing_row}]"))
    return Network(all_signals, (input_name,), tuple(compiled), variable)


def check_grid(omega: ArrayLike, what: str = "frequency grid") -> NDArray[np.float64]:
    """A 1-D, finite, strictly increasing, non-negative grid, or a `GridError`."""
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    if w.ndim != 1 or w.size == 0:
        raise GridError(f"{what} is empty or not one-dimensional")
    if not np.all(np.isfinite(w)):
        raise GridError(f"{what}: non-finite value at index {np.flatnonzero(~np.isfinite(w))[0]}")
    if np.any(w < 0):
        raise GridError(f"{what}: negative frequency at index {np.flatnonzero(w < 0)[0]}")
    steps = np.flatnonzero(np.diff(w) <= 0)
    if steps.size:
        raise GridError(f"{what}: not strictly increasing at index {steps[0] + 1} "
                        f"({w[steps[0]]:.6g} then {w[steps[0] + 1]:.6g})")
    return w


@dataclass(frozen=True)
class Solution:
    """Signals for one injection at every frequency, with sensitivities.

    x: (F, n); dx: (F, n, P) in the order of ``parameters``; dx_domega: (F, n) or None.
    """

    omega: NDArray[np.float64]
    x: NDArray[np.complex128]
    parameters: tuple[str, ...]
    dx: NDArray[np.complex128] | None
    dx_domega: NDArray[np.complex128] | None


def solve(network: Network, omega: ArrayLike, params: Mapping[str, float], inject: str, *,
          break_at: str | None = None, sensitivities: bool = True, d_omega: bool = False,
          check: bool = True) -> Solution:
    """Solve the network with a unit injection at signal ``inject``.

    With ``break_at``, every use of that signal is fed by the injection
    instead (then ``inject`` must equal ``break_at``).
    """
    w = check_grid(omega) if check else np.asarray(omega, dtype=float)
    _check_params(network, params)
    n, k = len(network.signals), network.signal(inject)
    broken = None if break_at is None else network.signal(break_at)
    x_var = 1j * w
    duals = _evaluate_entries(network, x_var, params, sensitivities, d_omega)
    M = np.zeros((w.size, n, n), dtype=complex)
    M[:, np.arange(n), np.arange(n)] = 1.0
    rhs = np.zeros((w.size, n), dtype=complex)
    if broken is None:
        rhs[:, k] = 1.0
    for entry, dual in zip(network.entries, duals):
        if entry.col == broken:
            rhs[:, entry.row] += dual.value
        else:
            M[:, entry.row, entry.col] -= dual.value
    x = _batched_solve(M, rhs[:, :, None], w, network)[:, :, 0]
    feed = x.copy()
    if broken is not None:
        feed[:, broken] = 1.0
    names = network.parameters
    columns = (len(names) if sensitivities else 0) + (1 if d_omega else 0)
    if columns == 0:
        return Solution(w, x, names, None, None)
    R = np.zeros((w.size, n, columns), dtype=complex)
    position = {p: i for i, p in enumerate(names)}
    for entry, dual in zip(network.entries, duals):
        source = feed[:, entry.col]
        if sensitivities:
            for p, g in dual.grad.items():
                R[:, entry.row, position[p]] += g * source
        if d_omega and dual.dvar is not None:
            R[:, entry.row, -1] += 1j * dual.dvar * source
    D = _batched_solve(M, R, w, network)
    dx = D[:, :, :len(names)] if sensitivities else None
    return Solution(w, x, names, dx, D[:, :, -1] if d_omega else None)


def _check_params(network: Network, params: Mapping[str, float]) -> None:
    for p in network.parameters:
        if p not in params:
            raise ParameterError(f"no value given for parameter {p!r}")
        if not np.isfinite(float(params[p])):
            raise ParameterError(f"parameter {p!r} is not finite ({params[p]!r})")


def _evaluate_entries(network: Network, x_var: NDArray, params: Mapping[str, float],
                      sensitivities: bool, d_omega: bool) -> list:
    duals = []
    for entry in network.entries:
        try:
            dual = entry.transfer.evaluate(x_var, params, d_omega)
        except EngineError as exc:
            raise type(exc)(f"{entry.label}: {exc}") from None
        bad = ~np.isfinite(dual.value)
        if np.any(bad):
            raise InterconnectionError(f"{entry.label} ({entry.transfer.text}) is not finite at "
                                       f"{np.abs(x_var[bad][0]):.6g} rad/s (a pole on the grid?)")
        duals.append(dual)
    return duals


def _batched_solve(M: NDArray, B: NDArray, w: NDArray, network: Network) -> NDArray:
    try:
        X = np.linalg.solve(M, B)
        bad = ~np.all(np.isfinite(X.reshape(X.shape[0], -1)), axis=1)
    except np.linalg.LinAlgError:
        bad = np.linalg.det(M) == 0
    if np.any(bad):
        raise InterconnectionError(f"the interconnection is singular at {w[bad][0]:.6g} rad/s "
                                   "(I - G has no inverse there)")
    return X

"""Interconnections: block diagrams and COEBRA's matrix format, compiled to one
form, solved for all frequencies at once with parameter sensitivities.

The compiled form is a set of signals x_1..x_n in which equation i defines
signal i:  x_i = sum_j G_ij(s) x_j  (+ an injection).  Exogenous inputs have
no terms.  M(s) x = b with M = I - G(s) is solved for all frequencies at once
by the sparse structure of G: a few "tear" signals cut every cycle, every
other signal follows in topological order as an affine function of the tears
(vectorized over frequencies), and a small batched solve closes the tears.
Sensitivities reuse the same schedule: M dx/dp = (dG/dp) x.

Breaking the loop at signal k replaces every *use* of x_k (column k of G) by
an injected unit signal v; the open loop is GH = -x_k (returned), so that the
closed-loop characteristic equation at that point is 1 + GH = 0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.derived import Derived, Form
from engine.errors import BlockError, EngineError, GridError, InterconnectionError, ParameterError
from engine.model.bilinear import Z_OF_W, check_sample_time, realization_in_w, refuse_above_nyquist
from engine.model.blocks import ExpressionTransfer, StateSpaceTransfer, Transfer
from engine.model.expressions import substituted
from engine.model.ports.state_space_ports import PortedStateSpace, StateSpaceChannel
from engine.numerics.polynomials import degree


@dataclass(frozen=True)
class Block:
    """output = transfer(s) * input; ``group`` gathers the blocks of one channel
    (a cascade of sub-compensators is shown multiplied out per group)."""

    name: str
    input: str
    output: str
    transfer: Transfer
    group: str = ""


@dataclass(frozen=True)
class PortedBlock:
    """A state space of m inputs and m outputs: ``outputs[i]`` = sum over j of its channel (i, j)
    times ``inputs[j]`` (`engine.model.ports.state_space_ports`)."""

    name: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    transfer: PortedStateSpace

    def __post_init__(self) -> None:
        m = self.transfer.ports
        for names, what in ((self.inputs, "input"), (self.outputs, "output")):
            if len(names) != m:
                raise InterconnectionError(
                    f"block {self.name!r}: {len(names)} {what} signals for a state space of {m} {what}s"
                )

    def blocks(self) -> list[Block]:
        """Its channels as blocks, each named after it (their entries share its states); a channel that is
        0 at every frequency is left out (no signal path: a decoupled block's off-diagonal)."""
        return [
            Block(self.name, self.inputs[j], self.outputs[i], self.transfer.channels[i][j])
            for i in range(len(self.outputs))
            for j in range(len(self.inputs))
            if not self.transfer.channel_is_zero(i, j)
        ]


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
    group: str = ""


@dataclass(frozen=True)
class Network:
    """The compiled interconnection (see module docstring)."""

    signals: tuple[str, ...]
    inputs: tuple[str, ...]
    entries: tuple[Entry, ...]
    variable: str = "s"
    sample_time: float | None = None
    index: dict[str, int] = field(default_factory=dict, compare=False, repr=False)
    derived: Derived = field(default_factory=Derived, init=False, compare=False, repr=False)  # schedules, designs

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

    @property
    def sampled(self) -> bool:
        """A loop in z with sample time T, held in its w-plane form (variable w, z = (1 + w)/(1 - w)):
        its frequencies are rad/s, each evaluated at w = j tan(omega T/2) (`points`)."""
        return self.sample_time is not None

    def points(self, omega: NDArray[np.float64]) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        """Where the blocks are evaluated at ``omega`` (rad/s), and d(point)/d(omega): j omega, or,
        for a sampled loop, w = j nu with nu = tan(omega T/2) up to the Nyquist frequency pi/T."""
        if self.sample_time is None:
            return 1j * omega, np.full(omega.shape, 1j)
        T = self.sample_time
        refuse_above_nyquist(omega, T)
        nu, slope = warped(omega, T)
        return 1j * nu, 1j * slope

    def unsampled(self) -> Network:
        """The same network read as a w-plane loop (its frequencies w-plane frequencies nu): kept, so that
        its designs are formed once."""
        if self.sample_time is None:
            return self
        return self.derived.get(W_PLANE, lambda: Network(self.signals, self.inputs, self.entries, self.variable))

    def signal(self, name: str) -> int:
        if name not in self.index:
            raise InterconnectionError(f"unknown signal {name!r}; signals are {', '.join(self.signals)}")
        return self.index[name]

    def on_a_loop(self, name: str) -> bool:
        """Does signal ``name`` feed back to itself through the entries (a cycle of the signal graph)?
        Breaking a signal on none opens no loop: the loop seen there is 0."""
        start = self.signal(name)
        users: dict[int, list[int]] = {}
        for e in self.entries:
            users.setdefault(e.col, []).append(e.row)
        seen, pending = set(), list(users.get(start, []))
        while pending:
            k = pending.pop()
            if k == start:
                return True
            if k not in seen:
                seen.add(k)
                pending.extend(users.get(k, []))
        return False


def warped(omega: NDArray[np.float64], sample_time: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A sampled loop's w-plane frequency nu = tan(omega T/2) of ``omega`` (rad/s, below pi/T) and
    d(nu)/d(omega) = (T/2)(1 + nu^2): the chain rule every derivative in omega goes through."""
    nu = np.tan(np.asarray(omega, dtype=float) * sample_time / 2.0)
    return nu, (sample_time / 2.0) * (1.0 + nu * nu)


def block_diagram(
    blocks: Sequence[Block | PortedBlock],
    junctions: Sequence[Junction] = (),
    inputs: Sequence[str] = (),
    variable: str = "s",
) -> Network:
    """Compile a block diagram; every signal read must be produced or a declared input."""
    producers: dict[str, str] = {name: f"input {name!r}" for name in inputs}
    for item in list(blocks) + list(junctions):
        kind = "junction" if isinstance(item, Junction) else "block"
        for output in item.outputs if isinstance(item, PortedBlock) else (item.output,):
            if output in producers:
                raise InterconnectionError(
                    f"signal {output!r} is produced by both {producers[output]} and {kind} {item.name!r}"
                )
            producers[output] = f"{kind} {item.name!r}"
    channels = [one for b in blocks for one in (b.blocks() if isinstance(b, PortedBlock) else [b])]
    signals = tuple(producers)
    index = {name: i for i, name in enumerate(signals)}

    def read(signal: str, who: str) -> int:
        if signal not in index:
            raise InterconnectionError(
                f"{who} reads signal {signal!r}, which no block or junction produces and which is not a declared input"
            )
        return index[signal]

    entries = [
        Entry(index[b.output], read(b.input, f"block {b.name!r}"), b.transfer, b.name, b.group) for b in channels
    ]
    for j in junctions:
        for sign, signal in j.terms:
            if sign not in (1, -1, 1.0, -1.0):
                raise InterconnectionError(f"junction {j.name!r}: sign must be +1 or -1, not {sign!r}")
            col = read(signal, f"junction {j.name!r}")
            entries.append(Entry(index[j.output], col, ExpressionTransfer(repr(float(sign)), variable), j.name))
    return Network(signals, tuple(inputs), tuple(entries), variable)


def matrix_format(
    signals: Sequence[str],
    entries: Mapping[tuple[int, int], str],
    forcing_row: int,
    forcing: str = "1",
    input_name: str = "theta",
    variable: str = "s",
) -> Network:
    """COEBRA's A(s) x = B theta with one forcing input (row and column indices from 1).

    Row i defines signal i: a_ii x_i + sum_j a_ij x_j = b_i theta, so
    x_i = sum_j (-a_ij/a_ii) x_j + (b_i/a_ii) theta.  Entries are rational
    expressions of any order.
    """
    n = len(signals)
    if len(set(signals)) != n or input_name in signals:
        raise InterconnectionError("matrix format: signal names must be distinct and differ from the input")
    for i, j in entries:
        if not (1 <= i <= n and 1 <= j <= n):
            raise InterconnectionError(f"matrix format: entry a[{i},{j}] is outside the {n}x{n} matrix")
    if not 1 <= forcing_row <= n:
        raise InterconnectionError(f"matrix format: forcing row {forcing_row} is outside 1..{n}")
    missing = [i for i in range(1, n + 1) if (i, i) not in entries]
    if missing:
        raise InterconnectionError(
            f"matrix format: row {missing[0]} has no diagonal entry "
            f"a[{missing[0]},{missing[0]}]; row i must define signal i"
        )
    all_signals = tuple(signals) + (input_name,)
    compiled = []
    for (i, j), text in sorted(entries.items()):
        if i == j:
            continue
        diag = entries[(i, i)]
        compiled.append(Entry(i - 1, j - 1, ExpressionTransfer(f"-({text})/({diag})", variable), f"a[{i},{j}]"))
    diag = entries[(forcing_row, forcing_row)]
    compiled.append(
        Entry(forcing_row - 1, n, ExpressionTransfer(f"({forcing})/({diag})", variable), f"b[{forcing_row}]")
    )
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
        raise GridError(
            f"{what}: not strictly increasing at index {steps[0] + 1} ({w[steps[0]]:.6g} then {w[steps[0] + 1]:.6g})"
        )
    return w


@dataclass(frozen=True)
class Solution:
    """Signals for one injection at every frequency, with sensitivities.

    x: (F, n).  dx: (F, len(rows), P) for the signals ``rows`` (all signals,
    or just the requested output), parameters in the order of ``parameters``.
    dx_domega: (F, len(rows)) or None.
    """

    omega: NDArray[np.float64]
    x: NDArray[np.complex128]
    parameters: tuple[str, ...]
    dx: NDArray[np.complex128] | None
    dx_domega: NDArray[np.complex128] | None
    rows: tuple[int, ...] = ()


def solve(
    network: Network,
    omega: ArrayLike,
    params: Mapping[str, float],
    inject: str,
    *,
    break_at: str | None = None,
    output: str | None = None,
    sensitivities: bool = True,
    d_omega: bool = False,
    check: bool = True,
) -> Solution:
    """Solve the network with a unit injection at signal ``inject``.

    With ``break_at``, every use of that signal is fed by the injection
    instead (then ``inject`` must equal ``break_at``).  Derivatives are of
    every signal, or, with ``output``, of that signal only by one adjoint
    solve (much cheaper with many parameters).  ``check=False`` skips
    validating a grid and parameters the caller has validated already.
    """
    w = check_grid(omega) if check else np.asarray(omega, dtype=float)
    if check:
        check_params(network, params)
    if d_omega and not network.exact:
        raise InterconnectionError("d/domega needs every block in closed form (a table has none)")
    n, k = len(network.signals), network.signal(inject)
    broken = None if break_at is None else network.signal(break_at)
    out = None if output is None else network.signal(output)
    point, slope = network.points(w)
    duals = _evaluate_entries(network, point, params, sensitivities, d_omega)
    values = [d.value for d in duals]
    # internal layout (signal, column, frequency): frequency last and contiguous
    rhs = np.zeros((n, 1, w.size), dtype=complex)
    if broken is None:
        rhs[k, 0] = 1.0
    for entry, dual in zip(network.entries, duals):
        if entry.col == broken:
            rhs[entry.row, 0] += dual.value
    x = sparse_solve(_schedule(network, broken, False), values, rhs, w)[:, 0, :]
    names = network.parameters
    if not (sensitivities or d_omega):
        return Solution(w, x.T, names, None, None)
    feed = x.copy()
    if broken is not None:
        feed[broken] = 1.0
    columns = [(number, p) for number, dual in enumerate(duals) for p in dual.grad] if sensitivities else []
    if out is not None:
        return _adjoint(network, duals, feed, names, columns, d_omega, broken, out, w, x, slope)
    R = np.zeros((n, len(names) + 1, w.size), dtype=complex)
    position = {p: i for i, p in enumerate(names)}
    for number, p in columns:
        e = network.entries[number]
        R[e.row, position[p]] += duals[number].grad[p] * feed[e.col]
    if d_omega:
        for e, dual in zip(network.entries, duals):
            R[e.row, -1] += slope * dual.dvar * feed[e.col]
    D = sparse_solve(_schedule(network, broken, False), values, R if d_omega else R[:, :-1], w)
    dx = D[:, : len(names), :].transpose(2, 0, 1) if sensitivities else None
    return Solution(w, x.T, names, dx, D[:, -1, :].T if d_omega else None, tuple(range(n)))


def _adjoint(
    network: Network,
    duals: list,
    feed: NDArray,
    names: tuple[str, ...],
    columns: list,
    d_omega: bool,
    broken: int | None,
    out: int,
    w: NDArray,
    x: NDArray,
    slope: NDArray,
) -> Solution:
    """d x_out / dp = y' R_p with (I - G)' y = e_out: one solve for any number of parameters."""
    n = len(network.signals)
    unit = np.zeros((n, 1, w.size), dtype=complex)
    unit[out, 0] = 1.0
    y = sparse_solve(_schedule(network, broken, True), [d.value for d in duals], unit, w)[:, 0, :]
    dx = np.zeros((w.size, 1, len(names)), dtype=complex)
    position = {p: i for i, p in enumerate(names)}
    for number, p in columns:
        e = network.entries[number]
        dx[:, 0, position[p]] += y[e.row] * duals[number].grad[p] * feed[e.col]
    dw = None
    if d_omega:
        dw = sum(y[e.row] * slope * dual.dvar * feed[e.col] for e, dual in zip(network.entries, duals))
        dw = np.asarray(dw, dtype=complex).reshape(w.size, 1)
    return Solution(w, x.T, names, dx if columns else None, dw, (out,))


def check_params(network: Network, params: Mapping[str, float]) -> None:
    """A ParameterError naming the first of the network's parameters without a value or with a
    value that is not finite (the one check of a network's parameters)."""
    for p in network.parameters:
        if p not in params:
            raise ParameterError(f"no value given for parameter {p!r}")
        if not math.isfinite(float(params[p])):
            raise ParameterError(f"parameter {p!r} is not finite ({params[p]!r})")


def _check_finite(entry: Entry, value: NDArray, x_var: NDArray) -> None:
    if np.isfinite(value).all():
        return
    bad = ~np.isfinite(value)
    if np.any(bad):
        raise InterconnectionError(
            f"{entry.label} ({entry.transfer.text}) is not finite at "
            f"{np.abs(x_var[bad][0]):.6g} rad/s (a pole on the grid?)"
        )


def _evaluate_entries(
    network: Network, x_var: NDArray, params: Mapping[str, float], sensitivities: bool, d_omega: bool
) -> list:
    duals = []
    for entry in network.entries:
        try:
            dual = entry.transfer.evaluate(x_var, params, d_omega, with_grad=sensitivities)
        except EngineError as exc:
            raise type(exc)(f"{entry.label}: {exc}") from None
        _check_finite(entry, dual.value, x_var)
        duals.append(dual)
    return duals


@dataclass(frozen=True)
class _Schedule:
    """How to solve (I - G) x = b (or its transpose): non-tear signals in
    topological order, the tears, and for each signal the (source, entry)
    pairs that feed it (the broken signal's uses excluded)."""

    order: tuple[int, ...]
    tears: tuple[int, ...]
    feeds: tuple[tuple[tuple[int, int], ...], ...]


SCHEDULE: Form[_Schedule] = Form("schedule")  # asked with the broken signal (or None) and whether transposed
W_PLANE: Form[Network] = Form("w-plane")


def _schedule(network: Network, broken: int | None, transposed: bool) -> _Schedule:
    """The schedule of the network broken at ``broken`` (or not), kept per case."""

    def made() -> _Schedule:
        edges = [
            ((e.col, e.row) if transposed else (e.row, e.col)) + (number,)
            for number, e in enumerate(network.entries)
            if e.col != broken
        ]
        return schedule_edges(len(network.signals), edges)

    return network.derived.get(SCHEDULE, made, broken, transposed)


def schedule_edges(n: int, edges: list[tuple[int, int, int]]) -> _Schedule:
    """Schedule for x_target += g_number * x_source over the (target, source, number) edges.

    Kahn's topological sort; when every remaining signal sits on a cycle, the
    one with most in x out connections becomes a tear.
    """
    feeds: list[list[tuple[int, int]]] = [[] for _ in range(n)]
    for target, source, number in edges:
        feeds[target].append((source, number))
    users: list[set[int]] = [set() for _ in range(n)]
    for i in range(n):
        for j, _ in feeds[i]:
            users[j].add(i)
    pending = [len({j for j, _ in feeds[i]}) for i in range(n)]
    done, order, tears = [False] * n, [], []
    ready = [i for i in range(n) if pending[i] == 0]
    while len(order) + len(tears) < n:
        if ready:
            i = ready.pop()
            order.append(i)
        else:
            i = max((j for j in range(n) if not done[j]), key=lambda j: (pending[j] * len(users[j]), -j))
            tears.append(i)
        done[i] = True
        for u in users[i]:
            pending[u] -= 1
            if pending[u] == 0 and not done[u]:
                ready.append(u)
    return _Schedule(tuple(order), tuple(tears), tuple(tuple(f) for f in feeds))


def sparse_solve(schedule: _Schedule, gains: Sequence[NDArray], B: NDArray, w: NDArray) -> NDArray:
    """X with (I - G) X = B; B and X of shape (n, m, F); ``gains[number]`` of shape (F,).

    Each signal is affine in the tears' values: x_i = a_i + c_i tau, kept as
    one row [a_i | c_i] of shape (m + t, F), so a feed costs one product."""
    n, m, F = B.shape
    t = len(schedule.tears)
    start = np.concatenate([B, np.zeros((n, t, F), dtype=complex)], axis=1) if t else B
    AC = np.empty((n, m + t, F), dtype=complex)
    for q, k in enumerate(schedule.tears):
        AC[k] = 0.0
        AC[k, m + q] = 1.0

    def affine(i: int) -> NDArray:
        feeds = schedule.feeds[i]
        if not feeds:
            return start[i]
        j, number = feeds[0]
        row = start[i] + gains[number] * AC[j]
        for j, number in feeds[1:]:
            row += gains[number] * AC[j]
        return row

    for i in schedule.order:
        AC[i] = affine(i)
    if t == 0:
        return AC
    closing = np.stack([affine(k) for k in schedule.tears])  # (t, m + t, F)
    lhs = np.eye(t)[None, :, :] - closing[:, m:].transpose(2, 0, 1)
    rhs = closing[:, :m].transpose(2, 0, 1)
    A, C = AC[:, :m], np.ascontiguousarray(AC[:, m:])
    with np.errstate(all="ignore"):
        try:
            tau = np.linalg.solve(lhs, rhs)
            bad = ~np.all(np.isfinite(tau.reshape(F, -1)), axis=1)
        except np.linalg.LinAlgError:
            bad = np.linalg.det(lhs) == 0
    if np.any(bad):
        raise InterconnectionError(
            f"the interconnection is singular at {w[bad][0]:.6g} rad/s (I - G has no inverse there)"
        )
    return A + np.einsum("ntf,ftm->nmf", C, tau)


GENERIC = 0.7371  # a parameter value no degree depends on (a block's degrees are read at it)


def _check_causal(transfer: ExpressionTransfer, label: str) -> None:
    """A block in z has no more zeros than poles: else its output leads its input (z^2/(z - 0.5)),
    which no computer can run, though its w-plane form is proper."""
    r = transfer.rational(dict.fromkeys(transfer.parameters, GENERIC))
    zeros, poles = degree(r.num), degree(r.den)
    if zeros > poles:
        raise BlockError(
            f"{label}: {transfer.text} has more zeros than poles in z ({zeros} over {poles}): not causal "
            "(its output would lead its input by a sample)"
        )


def sampled_network(network: Network, sample_time: float) -> Network:
    """A network of expressions in z as the sampled loop the engine analyzes: every z written
    (1 + w)/(1 - w), variable w, with its sample time (`Network.sampled`; the maps in
    `engine.model.bilinear`).  The factored forms
    cancel the (1 - w) this leaves exactly (`engine.model.factored`); no polynomial is expanded."""
    check_sample_time(sample_time)
    entries = []
    for e in network.entries:
        t = e.transfer
        if isinstance(t, StateSpaceTransfer):  # x[k+1] = A x[k] + B u[k]: in w, kept as state space
            try:
                w_form = (
                    t.in_w()  # the whole block's w-plane form, its states shared
                    if isinstance(t, StateSpaceChannel)
                    else StateSpaceTransfer(*realization_in_w(*t.realization()), source=f"{t.source}, in z")
                )
            except BlockError as exc:
                raise BlockError(f"{e.label}: {exc}") from None
            entries.append(replace(e, transfer=w_form))
            continue
        if not isinstance(t, ExpressionTransfer) or t.expression.variable != "z":
            raise BlockError(
                f"{e.label}: a loop in z takes expressions in z (polynomial, factored or typed) and state spaces, "
                f"not a {type(t).__name__} (discretize a continuous block first)"
            )
        if "w" in t.parameters:
            raise BlockError(f"{e.label}: a loop in z names w, the variable of its w-plane form: rename the parameter")
        _check_causal(t, e.label)
        entries.append(replace(e, transfer=ExpressionTransfer(substituted(t.text, "z", Z_OF_W), "w")))
    return Network(network.signals, network.inputs, tuple(entries), "w", sample_time)

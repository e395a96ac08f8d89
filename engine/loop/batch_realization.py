"""The state-space realizations of many samples of one network at once (a tolerance study's
samples: one diagram, other parameter values), as one `StateSpace` of stacked arrays: A (S, N, N),
B (S, N, I), C (S, n, N) and D (S, n, I), each sample's the one `engine.loop.realization.realize`
makes for it.

An entry whose parameters the samples do not vary is realized once, by `realize`'s own
entry realization; an entry they vary must fold to a ratio of degree <= 2 in every sample
(one controllable canonical section, `realize`'s for such a ratio), computed for every sample
at once from its folded coefficients.  A block of several ports
(`engine.model.ports.state_space_ports`) holds numbers, never parameters: its states are placed
once, where its first channel is, its B columns at the signals its inputs read and its C rows
at the signals its outputs write, its D in the feedthrough, as `realize` places them, and the
same in every sample.  When the direct feedthroughs are the same in every sample, I - D is
factored once, as `realize` factors it, and the signal equation solved for every sample's
state-to-signal map in one call; otherwise per sample.  A loop in z is realized in its w-plane
form (`engine.model.network.sampled_network`: variable w, each z written (1 + w)/(1 - w)), as
`realize` realizes it: a varied entry's (1 - w) factors its numerator and denominator share are
divided out before its section is made.  There is no batched realization (None; the per-sample
realization is the way) for a varied entry of higher degree, a delay or a table, or a singular
algebraic loop in a sample.

With ``shared``, blocks fed by one signal whose states move alike in every sample (the same A
and B: one denominator's controllable canonical section, as a bending mode's gyro, rate gyro
and accelerometer blocks are) share one set of states, each block's C reading them: the same
transfer from every input exactly, with fewer states (the launch vehicle's 28 are 16).  The
states left out are modes no input reaches (the copies' differences, autonomous: zero from a
zero state); their poles, the copies' own, are kept as ``hidden`` (`SharedStateSpace`): they
are poles of the loop, broken or closed, all the same.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.loop.pole_zero import BROKEN, broken_network
from engine.loop.realization import StateSpace, entry_realization, factored_feedthrough
from engine.model.blocks import ExpressionTransfer
from engine.model.expressions import Node
from engine.model.folding import FOLD_DEGREE
from engine.model.network import Network
from engine.model.ports.state_space_ports import StateSpaceChannel


@dataclass(frozen=True)
class SharedStateSpace(StateSpace):
    """Stacked realizations whose blocks of one input and one dynamics share their states
    (module docstring); ``hidden`` (S, h): the poles of the states left out."""

    hidden: NDArray[np.complex128] = field(default_factory=lambda: np.zeros((0, 0), dtype=complex))


def batch_loop_realization(
    network: Network, break_at: str, columns: Mapping[str, NDArray[np.float64]], shared: bool = False
) -> StateSpace | None:
    """Every sample's broken loop as `engine.loop.pole_zero.loop_realization` makes it (inputs: the
    network's, then the loop input), or with ``shared`` its blocks' states shared where they
    move alike (a `SharedStateSpace`); None when there is no batched realization."""
    broken = network.derived.get(BROKEN, lambda: broken_network(network, break_at), break_at)
    return batch_realize(broken, columns, shared)


def batch_closed_loop(network: Network, break_at: str, columns: Mapping[str, NDArray[np.float64]]) -> StateSpace | None:
    """Every sample's closed loop as `engine.loop.design.closed_loop_realization` makes it (the
    loop broken at ``break_at`` realized, then closed: `engine.loop.pole_zero.closed_from_broken`);
    None when there is no batched realization (module docstring)."""
    ss = batch_loop_realization(network, break_at, columns)
    return None if ss is None else closed_of(network, break_at, ss)


def closed_of(network: Network, break_at: str, ss: StateSpace) -> StateSpace | None:
    """The closed loops of the broken ones ``ss`` (`batch_loop_realization`), as
    `engine.loop.pole_zero.closed_from_broken` closes each; None for a singular algebraic loop."""
    closed = _closed(ss, network.signal(break_at))
    return None if closed is None else replace(closed, inputs=network.inputs, outputs=network.signals)


def closed_poles(ss: StateSpace, k: int) -> NDArray[np.complex128] | None:
    """Every sample's closed-loop poles (S, n) from its broken loop ``ss`` closed at signal ``k``
    (`closed_of`): the eigenvalues of the closed realization, as the per-loop stability row reads
    them (`engine.design.tableau.stability_abscissa`), and a `SharedStateSpace`'s hidden poles;
    None for a singular algebraic loop."""
    closed = _closed(ss, k)
    if closed is None:
        return None
    count, n = closed.A.shape[0], closed.A.shape[1]
    finite = np.isfinite(closed.A).all(axis=(1, 2))  # (a sample out of range: NaN poles, its forms odd)
    poles = np.linalg.eigvals(np.where(finite[:, None, None], closed.A, 0.0)) if n else np.zeros((count, 0), complex)
    poles = np.where(finite[:, None], poles, np.nan)
    return np.concatenate([poles, ss.hidden], axis=1) if isinstance(ss, SharedStateSpace) else poles


def _closed(ss: StateSpace, k: int) -> StateSpace | None:
    """`closed_of`'s matrices (the broken loop's inputs and outputs but the loop input's)."""
    Bu, Du = ss.B[:, :, -1:], ss.D[:, :-1, -1:]
    denominator = 1.0 - ss.D[:, k, -1][:, None, None]
    if (np.abs(denominator) < 1e-14).any():
        return None  # a singular algebraic loop: the per-sample realization says so
    Ck, Dk = ss.C[:, k : k + 1] / denominator, ss.D[:, k : k + 1, :-1] / denominator
    return replace(  # (a `SharedStateSpace` keeps its hidden poles: no input reaches them, open or closed)
        ss,
        A=ss.A + Bu @ Ck,
        B=ss.B[:, :, :-1] + Bu @ Dk,
        C=ss.C[:, :-1] + Du @ Ck,
        D=ss.D[:, :-1, :-1] + Du @ Dk,
        inputs=ss.inputs[:-1],
        outputs=ss.outputs[:-1],
    )


def samples(ss: StateSpace) -> list[StateSpace]:
    """Each sample's realization on its own (views of a stack's arrays; a loop in z's in w, with its sample time)."""
    return [StateSpace(A, B, C, D, ss.inputs, ss.outputs, ss.sample_time) for A, B, C, D in zip(ss.A, ss.B, ss.C, ss.D)]


def batch_realize(
    network: Network, columns: Mapping[str, NDArray[np.float64]], shared: bool = False
) -> StateSpace | None:
    """Every sample's `realize` (``columns``: each parameter's values, one per sample), its
    blocks' states shared where they move alike with ``shared``; None when there is no batched
    realization (module docstring)."""
    if not network.rational or network.variable != ("s" if network.sample_time is None else "w") or not columns:
        return None
    count = len(next(iter(columns.values())))
    try:
        units, feed = _units(network, columns, count)
        same = bool((feed == feed[:1]).all())
        factors = [factored_feedthrough(np.eye(len(network.signals)) - f) for f in (feed[:1] if same else feed)]
    except (EngineError, AttributeError, _Unbatched):
        return None
    if not shared:
        return _assembled(network, units, factors, count)
    owners = _owners(units)
    kept = [
        unit if owner == i else _Unit(unit.a[:, :0, :0], (), ()) for i, (owner, unit) in enumerate(zip(owners, units))
    ]
    readers = [(owner, c, row) for i, owner in enumerate(owners) if owner != i for row, c in units[i].writes]
    ss = _assembled(network, kept, factors, count, readers)
    left = [units[i].a for i, owner in enumerate(owners) if owner != i]
    hidden = np.concatenate([np.linalg.eigvals(a) for a in left], axis=1) if left else np.zeros((count, 0), complex)
    return SharedStateSpace(ss.A, ss.B, ss.C, ss.D, ss.inputs, ss.outputs, ss.sample_time, hidden=hidden)


@dataclass(frozen=True)
class _Unit:
    """One block's states in every sample: A (S, k, k), the columns of B by the signal each reads
    ((signal, (S, k)) pairs) and the rows of C by the signal each writes (a SISO entry: one of
    each; a block of several ports: one per port and signal, as `realize` places them)."""

    a: NDArray[np.float64]
    reads: tuple[tuple[int, NDArray[np.float64]], ...]
    writes: tuple[tuple[int, NDArray[np.float64]], ...]


class _Unbatched(Exception):
    """An entry with no batched realization (module docstring)."""


def _units(
    network: Network, columns: Mapping[str, NDArray[np.float64]], count: int
) -> tuple[list[_Unit], NDArray[np.float64]]:
    """The network's blocks' states in `realize`'s order, each sample's (a block of several ports
    once, where its first channel is) and the direct feedthroughs D (S, n, n); `_Unbatched` for an
    entry with no batched realization."""
    varied = {name for name, values in columns.items() if not (values == values[0]).all()}
    first = {name: float(values[0]) for name, values in columns.items()}
    n = len(network.signals)
    units: list[_Unit] = []
    ported: dict[int, tuple[int, dict, dict]] = {}  # id of a block -> its unit's place, reads, writes
    feed = np.zeros((count, n, n))
    for number, entry in enumerate(network.entries):
        t = entry.transfer
        if isinstance(t, StateSpaceChannel):  # its matrices are numbers: realized once, every sample's
            place, reads, writes = ported.setdefault(id(t.block), (len(units), {}, {}))
            if place == len(units):  # its first channel: its states go here
                units.append(_Unit(np.broadcast_to(t.block.A, (count, *t.block.A.shape)), (), ()))
            reads[(t.input_port, entry.col)] = np.broadcast_to(t.block.B[:, t.input_port], (count, t.block.order))
            writes[(t.output_port, entry.row)] = np.broadcast_to(t.block.C[t.output_port], (count, t.block.order))
            feed[:, entry.row, entry.col] += t.block.D[t.output_port, t.input_port]
            continue
        if set(t.parameters) & varied:
            made = _varied_section(t, columns, count, network.variable == "w")
            if made is None:
                raise _Unbatched
            a, b, c, d = made
        else:
            a1, b1, c1, d1 = entry_realization(network, number, first)
            a, b, c = (np.broadcast_to(m, (count, *m.shape)) for m in (a1, b1[:, 0], c1[0]))
            d = np.full(count, d1[0, 0] if d1.size else 0.0)
        units.append(_Unit(a, ((entry.col, b),), ((entry.row, c),)))
        feed[:, entry.row, entry.col] += d
    for place, reads, writes in ported.values():
        units[place] = replace(
            units[place],
            reads=tuple((col, b) for (_, col), b in reads.items()),
            writes=tuple((row, c) for (_, row), c in writes.items()),
        )
    return units, feed


def _owners(units: Sequence[_Unit]) -> list[int]:
    """For each block, the first block whose states it shares: fed by the one same signal, the
    same A and B in every sample (itself when none is)."""
    owners: list[int] = []
    for i, unit in enumerate(units):
        same = (
            j
            for j in range(i)
            if owners[j] == j
            and len(unit.reads) == len(units[j].reads) == 1
            and units[j].reads[0][0] == unit.reads[0][0]
            and unit.a.shape[1]
            and np.array_equal(units[j].a, unit.a)
            and np.array_equal(units[j].reads[0][1], unit.reads[0][1])
        )
        owners.append(next(same, i))
    return owners


def _varied_section(
    transfer, columns: Mapping[str, NDArray], count: int, sampled: bool = False
) -> tuple[NDArray, NDArray, NDArray, NDArray] | None:
    """A varied entry's realization in every sample: its folded ratio's controllable canonical
    section (`engine.loop.realization`'s for a ratio of degree <= 2; ``sampled``: an entry of a
    loop in z's w-plane form, its (1 - w) factors divided out first, `_without_ones`), or None
    (not such a ratio of one shape in every sample)."""
    if not isinstance(transfer, ExpressionTransfer):
        return None
    folded = _folded(transfer.expression.root, columns, count)
    if folded is None:
        return None
    num, den = (np.array(p).reshape(-1, count).T for p in folded)
    first = transfer.expression.folded({name: float(columns[name][0]) for name in transfer.parameters})
    if first is None or not (np.array_equal(first.num, num[0]) and np.array_equal(first.den, den[0])):
        return None  # not the per-sample fold (checked on the first sample)
    if sampled:
        divided = _without_ones(num, den)
        if divided is None:
            return None
        num, den = divided
    if not (num.shape[1] <= den.shape[1] <= 3) or (den[:, 0] == 0).any():
        return None
    if not (np.isfinite(num).all() and np.isfinite(den).all()):
        return None
    a = den / den[:, :1]
    b = np.concatenate([np.zeros((count, den.shape[1] - num.shape[1])), num], axis=1) / den[:, :1]
    k = den.shape[1] - 1
    A, B = np.zeros((count, k, k)), np.zeros((count, k))
    if k:  # (a static gain, degree 0: no states, its gain the feedthrough, as `cascade` makes it)
        A[:, 0] = -a[:, 1:]
        A[:, np.arange(1, k), np.arange(k - 1)] = 1.0
        B[:, 0] = 1.0
    return A, B, b[:, 1:] - b[:, :1] * a[:, 1:], b[:, 0]


def _without_ones(num: NDArray, den: NDArray) -> tuple[NDArray, NDArray] | None:
    """`engine.loop.realization`'s division of the factors (1 - w) that a w-plane entry's numerator
    and denominator share (both 0 at w = 1 to rounding, its test) for every sample (rows of
    descending coefficients), by the same arithmetic as np.polydiv's; None when the samples
    part ways (one divides where another does not) or a leading coefficient is 0 in some."""
    while True:
        if (num.shape[1] > 1 and (num[:, 0] == 0).any()) or (den[:, 0] == 0).any():
            return None  # (the per-loop path trims a leading zero: not batched)
        both = _vanishes(num) & _vanishes(den)
        if not both.any():
            return num, den
        if not both.all():
            return None
        num, den = _over_one_minus(num), _over_one_minus(den)


def _vanishes(p: NDArray) -> NDArray[np.bool_]:
    """Per row: is the polynomial 0 at w = 1 to rounding (np.polyval's Horner sum, against the
    sum of |coefficients|), as `engine.loop.realization` tests it?"""
    if p.shape[1] <= 1:
        return np.zeros(p.shape[0], dtype=bool)
    value = p[:, 0] * 1.0
    for j in range(1, p.shape[1]):
        value = value * 1.0 + p[:, j]
    return np.abs(value) <= 1e-12 * np.maximum(np.abs(p).sum(axis=1), 1e-300)


def _over_one_minus(p: NDArray) -> NDArray:
    """The quotient of every row by (w - 1), np.polydiv's steps: q_k = r_k, r_(k+1) += q_k."""
    q = np.empty((p.shape[0], p.shape[1] - 1))
    carry = p[:, 0] * 1.0
    q[:, 0] = carry
    for k in range(1, p.shape[1] - 1):
        carry = p[:, k] + carry
        q[:, k] = carry
    return q


def _assembled(
    network: Network,
    units: Sequence[_Unit],
    factors: list,
    count: int,
    readers: Sequence[tuple[int, NDArray, int]] = (),
) -> StateSpace:
    """`realize`'s assembly of the blocks' states for every sample: z' = A_blk z + B_blk x,
    x = (I - D)^-1 (C z + E u), with I - D factored once (``factors``: one LU) or per sample;
    ``readers``: (block, C, row) more outputs read from a block's states (blocks sharing them)."""
    from scipy import linalg  # on first use (start-up)

    n, m = len(network.signals), sum(unit.a.shape[1] for unit in units)
    A_blk, B_blk, C_sig = np.zeros((count, m, m)), np.zeros((count, m, n)), np.zeros((count, n, m))
    offset, states = 0, []
    for unit in units:
        sl = slice(offset, offset + unit.a.shape[1])
        A_blk[:, sl, sl] = unit.a
        for col, b in unit.reads:
            B_blk[:, sl, col] += b
        for row, c in unit.writes:
            C_sig[:, row, sl] += c
        offset += unit.a.shape[1]
        states.append(sl)
    for block, c, row in readers:
        C_sig[:, row, states[block]] += c
    E = np.zeros((n, len(network.inputs)))
    for k, name in enumerate(network.inputs):
        E[network.signal(name), k] = 1.0
    if len(factors) == 1:  # every sample's I - D alike: one solve for all
        columns = C_sig.transpose(1, 0, 2).reshape(n, count * m)
        P_state = linalg.lu_solve(factors[0], columns, check_finite=False).reshape(n, count, m).transpose(1, 0, 2)
        P_input = np.broadcast_to(linalg.lu_solve(factors[0], E, check_finite=False), (count, *E.shape))
    else:
        P_state = np.array([linalg.lu_solve(lu, c, check_finite=False) for lu, c in zip(factors, C_sig)])
        P_input = np.array([linalg.lu_solve(lu, E, check_finite=False) for lu in factors])
    A = A_blk + B_blk @ P_state
    return StateSpace(A, B_blk @ P_input, P_state, P_input, network.inputs, network.signals, network.sample_time)


Poly = tuple[NDArray, ...]  # descending coefficients, each every sample's (S,)


class _Apart(Exception):
    """The samples take different branches of the fold (a coefficient 0 in some only)."""


def _all(flags: NDArray) -> bool:
    """True when every sample's flag is, False when none is; `_Apart` otherwise."""
    if flags.all():
        return True
    if flags.any():
        raise _Apart
    return False


def _trimmed(a: Poly) -> Poly:
    i = 0
    while i < len(a) - 1 and _all(a[i] == 0.0):
        i += 1
    return a[i:]


def _times(a: Poly, b: Poly) -> Poly:
    out = [np.zeros_like(a[0])] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] = out[i + j] + x * y
    return _trimmed(tuple(out))


def _plus(a: Poly, b: Poly) -> Poly:
    if len(a) < len(b):
        a, b = b, a
    shift = len(a) - len(b)
    return _trimmed(tuple(x + b[i - shift] if i >= shift else x for i, x in enumerate(a)))


def _folded(root: Node, columns: Mapping[str, NDArray], count: int) -> tuple[Poly, Poly] | None:
    """The expression's ratio of degree <= `FOLD_DEGREE` in every sample, by
    `engine.model.folding.compile_tree`'s arithmetic on every sample at once (its branches taken
    alike in every sample); None when it does not fold so (or the samples part ways)."""
    try:
        found = _fold(root, columns, np.ones(count))
    except _Apart:
        return None
    if found is None or max(len(found[0]), len(found[1])) - 1 > FOLD_DEGREE:
        return None
    return found[0], found[1]


def _fold(node: Node, columns: Mapping[str, NDArray], one: NDArray) -> tuple[Poly, Poly, bool] | None:
    """(numerator, denominator, typed) of a subtree as `compile_tree` folds it; None when it does not."""
    if node.op == "num":
        return (node.value * one,), (one,), True
    if node.op == "var":
        return (one, 0 * one), (one,), True
    if node.op == "param":
        return (np.asarray(columns[node.name], dtype=float),), (one,), True
    args = [_fold(a, columns, one) for a in node.args]
    if any(a is None for a in args):
        return None
    num, den, typed = _combined(node, args, one)
    return (num, den, typed) if max(len(num), len(den)) - 1 <= FOLD_DEGREE or typed else None


def _unit(p: Poly) -> bool:
    return len(p) == 1 and _all(p[0] == 1.0)


def _combined(node: Node, args: list, one: NDArray) -> tuple[Poly, Poly, bool]:
    """`Folded.combine` of the arguments' folds."""
    (num, den, typed), other = args[0], args[1] if len(args) > 1 else None
    op, exponent = node.op, node.exponent
    monomial = _unit(den) and all(_all(c == 0.0) or _all(c != 0.0) for c in num)
    monomial = monomial and sum(_all(c != 0.0) for c in num) <= 1
    if op == "neg":
        return tuple(-c for c in num), den, typed and _unit(den)
    if op == "pow":
        base = (num, den) if exponent >= 0 else (den, num)
        top, bottom = (one,), (one,)
        for _ in range(abs(exponent)):
            top, bottom = _times(top, base[0]), _times(bottom, base[1])
        return top, bottom, typed and _unit(den) and monomial and exponent >= 0
    o_num, o_den, o_typed = other
    kept = typed and _unit(den) and o_typed and _unit(o_den)
    if op in ("add", "sub"):
        signed = o_num if op == "add" else tuple(-c for c in o_num)
        if len(den) == len(o_den) and all(_all(a == b) for a, b in zip(den, o_den)):
            return _plus(num, signed), den, kept
        return _plus(_times(num, o_den), _times(signed, den)), _times(den, o_den), kept
    if op == "mul":
        o_monomial = sum(_all(c != 0.0) for c in o_num) <= 1 and all(_all(c == 0.0) or _all(c != 0.0) for c in o_num)
        degree_zero = max(len(num), len(den)) == 1 or max(len(o_num), len(o_den)) == 1
        return _times(num, o_num), _times(den, o_den), kept and (degree_zero or (monomial and o_monomial))
    return _times(num, o_den), _times(den, o_num), kept and max(len(o_num), len(o_den)) == 1

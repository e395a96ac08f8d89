"""The pole-zero forms of many loops of one structure at once: the loops of a
tolerance study share their network and expressions and differ in the numbers.

Each block's expression is read factor by factor from its tree, as
`engine.model.factored` reads it for one loop, with every quantity carrying a
leading axis of samples: products and quotients join root arrays, a sum
(or a leaf) is folded to its small polynomial over its terms' common
denominator and only its roots are computed, those of degree two and more by
one batched eigenvalue call on the stacked companion matrices (numpy's
``np.roots`` matrix, so each sample's roots are the ones the per-loop path
computes).  GH = -(the chain's product) for a loop that is one cascade.

A zero-pole pair equal in every sample (a common factor of the structure: the
(1 - w) each z = (1 + w)/(1 - w) of a loop in z's w-plane form brings) cancels, and
a pole at one value in every sample that several terms of a sum hold is held once by
their common denominator, as the per-loop path does.
A sample whose numbers leave the shared structure is marked ``odd`` and left
to the per-loop path: a pole shared by two terms of a sum (within
`engine.model.factored.CANCEL`: the per-loop path merges it), a zero that
cancels a pole, a leading or trailing coefficient that vanishes, a gain of
zero under a quotient, a number out of range, a sum of fractions whose
numerator's roots are not its zeros to `engine.model.factored.BACKWARD` (lightly
damped modes close together: the per-loop path polishes them).  A loop that is not a cascade
of expression blocks (a delay, a table, a state space, inner loops) has no
batch form (None).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.loop.evaluator import LoopEvaluator
from engine.model.blocks import ExpressionTransfer
from engine.model.expressions import Node
from engine.model.factored import BACKWARD, CANCEL, MAX_ORDER, signed_terms
from engine.model.network import Network


@dataclass
class Stack:
    """gain * prod(x - zeros) / prod(x - poles) for every sample: gain (S,), zeros (S, m),
    poles (S, n); ``odd`` (S,) marks the samples this shared structure does not describe."""

    gain: NDArray[np.float64]
    zeros: NDArray[np.complex128]
    poles: NDArray[np.complex128]
    odd: NDArray[np.bool_]

    def times(self, other: Stack) -> Stack:
        return Stack(
            self.gain * other.gain,
            np.concatenate([self.zeros, other.zeros], axis=1),
            np.concatenate([self.poles, other.poles], axis=1),
            self.odd | other.odd,
        )

    def reciprocal(self) -> Stack:
        return Stack(
            1.0 / np.where(self.gain == 0, 1.0, self.gain), self.poles, self.zeros, self.odd | (self.gain == 0)
        )

    def power(self, k: int) -> Stack:
        base = self if k >= 0 else self.reciprocal()
        k = abs(k)
        if max(base.zeros.shape[1], base.poles.shape[1]) * k > MAX_ORDER:
            raise EngineError(f"order beyond the limit of {MAX_ORDER} for one block")
        return Stack(np.power(base.gain, k), np.tile(base.zeros, k), np.tile(base.poles, k), base.odd)


def block_stack(expression_root: Node, columns: Mapping[str, NDArray[np.float64]], count: int) -> Stack:
    """One expression's pole-zero form for every sample (``columns``: each parameter's
    values), its zero-pole pairs that cancel in any sample marking that sample odd."""
    with np.errstate(all="ignore"):
        form = _cancelled(_node(expression_root, columns, count))
        finite = np.isfinite(form.gain) & _finite_rows(form.zeros) & _finite_rows(form.poles)
        return Stack(form.gain, form.zeros, form.poles, form.odd | ~finite | _meet(form.zeros, form.poles))


def _cancelled(form: Stack) -> Stack:
    """The form with every zero-pole pair equal in every sample removed: a common factor of the
    structure, such as the (1 - w) each z = (1 + w)/(1 - w) of a loop in z brings (its root is
    1 exactly), which the per-loop path cancels as well."""
    if form.zeros.shape[1] == 0 or form.poles.shape[1] == 0:
        return form
    equal = (form.zeros[:, :, None] == form.poles[:, None, :]).all(axis=0)
    zeros, poles = list(range(form.zeros.shape[1])), list(range(form.poles.shape[1]))
    for i, j in zip(*np.nonzero(equal)):
        if i in zeros and j in poles:
            zeros.remove(i)
            poles.remove(j)
    return Stack(form.gain, form.zeros[:, zeros], form.poles[:, poles], form.odd)


def _finite_rows(roots: NDArray) -> NDArray[np.bool_]:
    return np.isfinite(roots).all(axis=1)


def _meet(a: NDArray, b: NDArray) -> NDArray[np.bool_]:
    """Per sample: is any root of ``a`` within `CANCEL` (relative to the larger, or 1) of any root of ``b``?"""
    if a.shape[1] == 0 or b.shape[1] == 0:
        return np.zeros(a.shape[0], dtype=bool)
    gap = np.abs(a[:, :, None] - b[:, None, :])
    size = np.maximum(np.maximum(np.abs(a)[:, :, None], np.abs(b)[:, None, :]), 1.0)
    return (gap <= CANCEL * size).any(axis=(1, 2))


def _node(node: Node, columns: Mapping[str, NDArray], count: int) -> Stack:
    if node.op == "mul":
        return _node(node.args[0], columns, count).times(_node(node.args[1], columns, count))
    if node.op == "div":
        return _node(node.args[0], columns, count).times(_node(node.args[1], columns, count).reciprocal())
    if node.op == "pow":
        return _node(node.args[0], columns, count).power(node.exponent)
    if node.op == "neg":
        inner = _node(node.args[0], columns, count)
        return Stack(-inner.gain, inner.zeros, inner.poles, inner.odd)
    if node.op in ("add", "sub"):
        return _sum(signed_terms(node), columns, count)
    return _leaf(node, columns, count)


def _leaf(node: Node, columns: Mapping[str, NDArray], count: int) -> Stack:
    """A number, a parameter or the variable."""
    none = np.zeros((count, 0), dtype=complex)
    if node.op == "var":
        return Stack(np.ones(count), np.zeros((count, 1), dtype=complex), none, np.zeros(count, dtype=bool))
    value = np.full(count, node.value) if node.op == "num" else np.asarray(columns[node.name], dtype=float)
    return Stack(value.copy(), none, none.copy(), ~np.isfinite(value))


def _sum(terms: list[tuple[float, Node]], columns: Mapping[str, NDArray], count: int) -> Stack:
    """A sum over its terms' common denominator, the terms' poles kept as roots; a sample where
    two terms share a pole (the per-loop path merges them) is odd, but for a pole every sample
    has exactly (a constant of the structure, such as the 1 of each (1 - w) in a loop in z's
    w-plane form), which the common denominator holds once, at its largest multiplicity."""
    forms = [(sign, _node(term, columns, count)) for sign, term in terms]
    own, shared, lacking = _shared_poles([form.poles for _, form in forms], count)
    odd = np.zeros(count, dtype=bool)
    for k, (_, form) in enumerate(forms):
        odd |= form.odd
        for j, (_, earlier) in enumerate(forms[:k]):
            odd |= _meet(own[k], earlier.poles) | _meet(form.poles, own[j])
    others = [np.concatenate([lacking[k], *own[:k], *own[k + 1 :]], axis=1) for k in range(len(forms))]
    numerator = np.zeros((count, 1))
    for (sign, form), rest in zip(forms, others):
        roots = np.concatenate([form.zeros, rest], axis=1)
        numerator = _added(numerator, (sign * form.gain)[:, None] * _poly(roots).real)
    common = np.concatenate([*own, shared], axis=1)
    while numerator.shape[1] > 1 and (numerator[:, 0] == 0).all():  # a degree the structure drops ((z + 1) in w)
        numerator = numerator[:, 1:]
    odd |= (numerator[:, 0] == 0) | ~np.isfinite(numerator).all(axis=1)
    zeros, bad = _roots(numerator)
    if common.shape[1] and zeros.shape[1]:  # a sum of fractions: its numerator's roots only estimate its zeros
        bad |= _backward_errors(forms, others, zeros) > BACKWARD
    return Stack(numerator[:, 0].copy(), zeros, common, odd | bad)


def _shared_poles(poles: list[NDArray], count: int) -> tuple[list[NDArray], NDArray, list[NDArray]]:
    """Of the terms' poles: each term's own (all but those at a value several terms hold in
    every sample exactly), the shared ones at their largest multiplicity, and the shared ones
    each term lacks (its numerator's multiplier)."""
    constant = [(roots == roots[:1]).all(axis=0) if count else np.zeros(roots.shape[1], dtype=bool) for roots in poles]
    held = [Counter(roots[0, mask].tolist()) if count else Counter() for roots, mask in zip(poles, constant)]
    shared = {v: max(c[v] for c in held) for v in set().union(*held) if sum(v in c for c in held) > 1}
    if not shared:  # the common case, a chunk's fixed cost: no term's poles to set apart
        none = np.zeros((count, 0), dtype=complex)
        return list(poles), none, [none] * len(poles)
    own = [
        roots[:, ~(mask & np.isin(roots[0], list(shared)))] if count else roots for roots, mask in zip(poles, constant)
    ]

    def column(values: list[complex]) -> NDArray:
        return np.tile(np.array(values, dtype=complex).reshape(1, -1), (count, 1))

    lacking = [column([v for v, n in shared.items() for _ in range(n - c[v])]) for c in held]
    return own, column([v for v, n in shared.items() for _ in range(n)]), lacking


def _backward_errors(forms: list[tuple[float, Stack]], others: list[NDArray], zeros: NDArray) -> NDArray[np.float64]:
    """Per sample, the largest backward error of its zeros as zeros of the sum's numerator N = sum N_k,
    each N_k in factored form (its zeros and ``others[k]``, the common denominator's poles it
    lacks; never the expanded numerator): |N| / (sum |N_k| + |x| sum |N_k'|), the
    per-loop path's measure (`engine.model.factored`).  Beyond `BACKWARD` (lightly damped modes close
    together: the expanded numerator's roots are off) the sample goes to the per-loop path, which
    polishes them."""
    x = zeros[:, :, None]  # (S, m, 1)
    value = np.zeros(zeros.shape, dtype=complex)
    size = np.zeros(zeros.shape)
    with np.errstate(all="ignore"):
        for (sign, form), rest in zip(forms, others):
            roots = np.concatenate([form.zeros, rest], axis=1)[:, None, :]  # (S, 1, r)
            factors = x - roots
            term = (sign * form.gain)[:, None] * np.prod(factors, axis=2)
            slope = term * np.sum(1.0 / factors, axis=2)
            slope = np.where(np.isfinite(slope), slope, 0.0)  # x on one of the term's roots: it adds nothing there
            value += term
            size += np.abs(term) + np.abs(zeros) * np.abs(slope)
        error = np.where(value == 0, 0.0, np.abs(value) / size)
    return np.max(np.where(np.isfinite(error), error, np.inf), axis=1)


def _poly(roots: NDArray) -> NDArray[np.complex128]:
    """np.poly of every row: the products (1, -r) convolved in the roots' order."""
    c = np.ones((roots.shape[0], 1), dtype=complex)
    for k in range(roots.shape[1]):
        nxt = np.zeros((c.shape[0], c.shape[1] + 1), dtype=complex)
        nxt[:, :-1] = c
        nxt[:, 1:] += c * -roots[:, k : k + 1]
        c = nxt
    return c


def _added(a: NDArray, b: NDArray) -> NDArray:
    """np.polyadd of every row (aligned at the constant term)."""
    if a.shape[1] < b.shape[1]:
        a, b = b, a
    out = a.copy()
    out[:, a.shape[1] - b.shape[1] :] = out[:, a.shape[1] - b.shape[1] :] + b
    return out


def _roots(c: NDArray) -> tuple[NDArray[np.complex128], NDArray[np.bool_]]:
    """The roots of every row (leading coefficient nonzero) as the per-loop path takes them:
    a x + b directly, higher degrees as np.roots does, in one batched eigenvalue call; and
    the samples this does not describe (a vanishing constant term, roots out of range)."""
    count, n = c.shape[0], c.shape[1] - 1
    if n == 0:
        return np.zeros((count, 0), dtype=complex), np.zeros(count, dtype=bool)
    if n == 1:
        roots = (-c[:, 1:] / c[:, :1]).astype(complex)
        return roots, ~np.isfinite(roots).all(axis=1)
    bad = c[:, -1] == 0
    lead = np.where(bad, 1.0, c[:, 0])
    companion = np.zeros((count, n, n))
    companion[:, 1:, :-1] = np.eye(n - 1)
    companion[:, 0, :] = -np.where(bad[:, None], 1.0, c[:, 1:]) / lead[:, None]
    finite = np.isfinite(companion).all(axis=(1, 2))
    companion[~finite] = np.eye(n)
    roots = np.linalg.eigvals(companion).astype(complex)
    return roots, bad | ~finite | ~np.isfinite(roots).all(axis=1)


@dataclass
class BatchForms:
    """The open loops GH = gain prod(s - zeros) / prod(s - poles) of many samples of one
    structure; ``odd``: the samples left to the per-loop path."""

    gain: NDArray[np.float64]
    zeros: NDArray[np.complex128]
    poles: NDArray[np.complex128]
    odd: NDArray[np.bool_]


def batch_pole_zero(network: Network, break_at: str, columns: Mapping[str, NDArray[np.float64]]) -> BatchForms | None:
    """The loop broken at ``break_at`` for every sample (``columns``: each parameter's values,
    one per sample) in pole-zero form; None when the loop is not one cascade of expression
    blocks (module docstring)."""
    count = len(next(iter(columns.values()))) if columns else 1
    if not network.rational:
        return None
    first = {name: float(values[0]) for name, values in columns.items()}
    try:
        chain = LoopEvaluator(network, break_at, first).cascade()
    except EngineError:
        return None
    if chain is None or not all(isinstance(network.entries[k].transfer, ExpressionTransfer) for k in chain):
        return None
    total = Stack(-np.ones(count), *(np.zeros((count, 0), dtype=complex),) * 2, np.zeros(count, dtype=bool))
    try:
        for number in chain:
            total = total.times(block_stack(network.entries[number].transfer.expression.root, columns, count))
    except EngineError:
        return None
    if total.poles.shape[1] == 0:
        return None
    return BatchForms(total.gain, total.zeros, total.poles, total.odd)

"""An expression's pole-zero form, read factor by factor from its tree.

Expanding a product such as (s + 0.001)(s + 0.002)...(s^2 + ...) into one
polynomial and asking for its roots loses digits: the roots of a polynomial
of degree 16 given by its coefficients can be wrong in the third digit when
they cluster.  The tree of a typed expression usually keeps the factors, so
the roots are taken where they are: products, quotients and integer powers
combine root lists; a sum (or a number, a name, the variable) is folded to
its own, small polynomial ratio and only its roots are computed.  Equal
roots of the numerator and the denominator cancel (H((1 + w)/(1 - w)) has
(1 - w) factors that cancel exactly), within `CANCEL` relative.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.errors import ExpressionError
from engine.model.expressions import Expression, Node
from engine.model.folding import to_rational
from engine.numerics.polynomials import trim

CANCEL = 1e-10  # relative distance at which a zero and a pole are the same root
MAX_ORDER = 400  # roots of one block: beyond, its realization alone would take minutes


@dataclass(frozen=True)
class PoleZero:
    """gain * prod(x - zeros) / prod(x - poles)."""

    gain: float
    zeros: NDArray[np.complex128]
    poles: NDArray[np.complex128]

    def __mul__(self, other: PoleZero) -> PoleZero:
        return PoleZero(
            self.gain * other.gain, np.concatenate([self.zeros, other.zeros]), np.concatenate([self.poles, other.poles])
        )

    def reciprocal(self) -> PoleZero:
        if self.gain == 0:
            raise ExpressionError("division by zero")
        return PoleZero(1.0 / self.gain, self.poles, self.zeros)

    def power(self, k: int) -> PoleZero:
        base = self if k >= 0 else self.reciprocal()
        k = abs(k)
        if max(base.zeros.size, base.poles.size) * k > MAX_ORDER:
            raise ExpressionError(
                f"order {max(base.zeros.size, base.poles.size) * k} is beyond the limit of {MAX_ORDER} for one block"
            )
        with np.errstate(all="ignore"):
            gain = float(np.float64(base.gain) ** k)  # a Python float's ** raises OverflowError
        return PoleZero(gain, np.tile(base.zeros, k), np.tile(base.poles, k))

    def evaluate(self, x: NDArray[np.complex128]) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        """The value and d/dx at ``x``, a zero and a pole paired in each factor: no partial
        product over- or underflows where a tree's product of many factors can."""
        x = np.asarray(x, dtype=complex)[..., None]
        m = min(self.zeros.size, self.poles.size)
        with np.errstate(all="ignore"):
            zq, pq = x - self.zeros, x - self.poles
            value = self.gain * np.prod(zq[..., :m] / pq[..., :m], axis=-1)
            value = value * np.prod(zq[..., m:], axis=-1) / np.prod(pq[..., m:], axis=-1)
            lost = ~np.isfinite(value) | (value == 0)  # still beyond the range: by logarithms
            if lost.any() and self.gain != 0:
                logs = np.sum(np.log(zq[lost]), axis=-1) - np.sum(np.log(pq[lost]), axis=-1)
                value[lost] = np.sign(self.gain) * np.exp(logs + np.log(abs(self.gain)))
            return value, value * (np.sum(1.0 / zq, axis=-1) - np.sum(1.0 / pq, axis=-1))

    def cancelled(self) -> PoleZero:
        """Without the zero-pole pairs that are the same root."""
        zeros, poles = list(self.zeros), list(self.poles)
        kept_zeros = []
        for z in zeros:
            match = _matching(poles, z)
            if match is None:
                kept_zeros.append(z)
            else:
                poles.pop(match)
        return PoleZero(self.gain, np.array(kept_zeros, dtype=complex), np.array(poles, dtype=complex))


def pole_zero(expression: Expression, params: Mapping[str, float]) -> PoleZero:
    """The expression's gain, zeros and poles, factor by factor, cancelled
    (kept on the expression for its last parameter values: the realization
    and the pole polishing both ask)."""
    return expression._cached("pole zero", params, lambda: _checked(expression, params))


def _checked(expression: Expression, params: Mapping[str, float]) -> PoleZero:
    try:
        with np.errstate(all="ignore"):
            form = _node(expression.root, params)
    except ExpressionError as exc:
        if exc.expression:
            raise
        raise ExpressionError(str(exc), expression.text) from None
    if not (np.isfinite(form.gain) and np.all(np.isfinite(form.zeros)) and np.all(np.isfinite(form.poles))):
        raise ExpressionError(
            f"its numbers leave the floating-point range (gain {form.gain:.3g}, roots beyond 1e308 or not numbers)",
            expression.text,
        )
    order = max(form.zeros.size, form.poles.size)
    if order > MAX_ORDER:
        raise ExpressionError(f"order {order} is beyond the limit of {MAX_ORDER} for one block", expression.text)
    return form.cancelled()


def _node(node: Node, params: Mapping[str, float]) -> PoleZero:
    if node.op == "mul":
        return _node(node.args[0], params) * _node(node.args[1], params)
    if node.op == "div":
        return _node(node.args[0], params) * _node(node.args[1], params).reciprocal()
    if node.op == "pow":
        return _node(node.args[0], params).power(node.exponent)
    if node.op == "neg":
        inner = _node(node.args[0], params)
        return PoleZero(-inner.gain, inner.zeros, inner.poles)
    if node.op in ("add", "sub"):
        return _sum(signed_terms(node), params)
    return _leaf(node, params)


def _leaf(node: Node, params: Mapping[str, float]) -> PoleZero:
    """A number, a parameter or the variable."""
    none = np.zeros(0, dtype=complex)
    if node.op == "var":
        return PoleZero(1.0, np.zeros(1, dtype=complex), none)
    value = float(to_rational(node, params).num[0])
    if not np.isfinite(value):
        raise ExpressionError("polynomial coefficients overflow")
    return PoleZero(value, none, none)


def signed_terms(node: Node) -> list[tuple[float, Node]]:
    """A run of + and - as its signed terms (a - (b - c) is a - b + c)."""
    out, stack = [], [(1.0, node)]
    while stack:
        sign, item = stack.pop()
        if item.op in ("add", "sub"):
            stack.append((sign if item.op == "add" else -sign, item.args[1]))
            stack.append((sign, item.args[0]))
        else:
            out.append((sign, item))
    return out


def _sum(terms: list[tuple[float, Node]], params: Mapping[str, float]) -> PoleZero:
    """A sum over the least common denominator of its terms: a pole that terms share (the
    same root, within CANCEL) is one pole of the sum, not a pole of each (over the product
    of the denominators, Z^2 - 0.5 Z with Z = (1 + w)/(1 - w) had a third pole at w = 1 and
    a zero beside it, a pair that no longer cancelled once the roots were recomputed).
    Only the numerator is multiplied out; the terms' own factors are kept as roots."""
    forms = [(sign, _node(term, params)) for sign, term in terms]
    common: list[complex] = []
    for _, form in forms:
        missing = list(form.poles)
        for p in common:
            k = _matching(missing, p)
            if k is not None:
                missing.pop(k)
        common += missing
    numerator = np.zeros(1)
    for sign, form in forms:
        rest = list(common)
        for p in form.poles:
            rest.pop(_matching(rest, p))
        term = sign * form.gain * np.poly(np.concatenate([form.zeros, np.array(rest, dtype=complex)])).real
        numerator = np.polyadd(numerator, term)
    numerator = trim(numerator)
    if not np.all(np.isfinite(numerator)):
        raise ExpressionError("polynomial coefficients overflow")
    zeros = (
        _roots(numerator).astype(complex) if numerator.size > 1 and numerator[0] != 0 else np.zeros(0, dtype=complex)
    )
    return PoleZero(float(numerator[0]), zeros, np.array(common, dtype=complex))


def _matching(roots: list[complex], root: complex) -> int | None:
    """The index of the first of ``roots`` that is ``root`` within CANCEL of it, or None."""
    return next((k for k, r in enumerate(roots) if abs(root - r) <= CANCEL * max(1.0, abs(r))), None)


def _roots(c: NDArray) -> NDArray:
    """np.roots, without its eigenvalue problem for a first-order factor a x + b
    (b != 0): its companion matrix is the number -b/a, which is the root."""
    if not np.all(np.isfinite(c)):
        raise ExpressionError("polynomial coefficients overflow")
    with np.errstate(all="ignore"):
        if c.size == 2 and c[1] != 0:
            roots = -c[1:] / c[0]
        else:
            try:
                roots = np.roots(c)
            except np.linalg.LinAlgError:  # its companion matrix is not finite: a denormal leading coefficient
                roots = np.full(1, np.inf)
    if not np.all(np.isfinite(roots)):
        raise ExpressionError("a root lies beyond the floating-point range (a leading coefficient near 0?)")
    return roots

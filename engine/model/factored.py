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
        return PoleZero(base.gain**k, np.tile(base.zeros, k), np.tile(base.poles, k))

    def cancelled(self) -> PoleZero:
        """Without the zero-pole pairs that are the same root."""
        zeros, poles = list(self.zeros), list(self.poles)
        kept_zeros = []
        for z in zeros:
            match = next((k for k, p in enumerate(poles) if abs(z - p) <= CANCEL * max(1.0, abs(p))), None)
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
    form = _node(expression.root, params)
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
    return _folded(node, params)


def _folded(node: Node, params: Mapping[str, float]) -> PoleZero:
    """A sum or a leaf: its own polynomial ratio, then its roots."""
    r = to_rational(node, params)
    num, den = trim(r.num), trim(r.den)
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        raise ExpressionError("polynomial coefficients overflow")
    if den[0] == 0:
        raise ExpressionError("division by zero")
    gain = float(num[0] / den[0])
    zeros = _roots(num) if num.size > 1 and num[0] != 0 else np.zeros(0, dtype=complex)
    poles = _roots(den) if den.size > 1 else np.zeros(0, dtype=complex)
    return PoleZero(gain, zeros.astype(complex), poles.astype(complex))


def _roots(c: NDArray) -> NDArray:
    """np.roots, without its eigenvalue problem for a first-order factor a x + b
    (b != 0): its companion matrix is the number -b/a, which is the root."""
    if c.size == 2 and c[1] != 0:
        return -c[1:] / c[0]
    return np.roots(c)

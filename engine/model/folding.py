"""Expression trees made fast: constant subtrees folded to polynomial ratios,
the rest compiled to closures over numpy arrays (value and derivative in
the variable), and the exact `Rational` form for given parameter values.
`engine.model.expressions` parses; this module evaluates what it parsed."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from engine.numerics.polynomials import Rational

if TYPE_CHECKING:
    from engine.model.expressions import Node


def to_rational(node: Node, params: Mapping[str, float]) -> Rational:
    op = node.op
    if op == "num":
        return Rational.constant(node.value)
    if op == "var":
        return Rational.variable()
    if op == "param":
        return Rational.constant(float(params[node.name]))
    return _combine_rationals(op, [to_rational(a, params) for a in node.args], node.exponent)


def _combine_rationals(op: str, args: list[Rational], exponent: int) -> Rational:
    if op == "neg":
        return -args[0]
    if op == "pow":
        return args[0] ** exponent
    if op == "add":
        return args[0] + args[1]
    if op == "sub":
        return args[0] - args[1]
    if op == "mul":
        return args[0] * args[1]
    return args[0] / args[1]


FOLD_DEGREE = 2
Evaluator = Callable[[NDArray], tuple[NDArray, NDArray]]
Poly = tuple[float, ...]  # descending coefficients, plain floats: fast for tiny polynomials


def _ptrim(a: Poly) -> Poly:
    i = 0
    while i < len(a) - 1 and a[i] == 0.0:
        i += 1
    return a[i:]


def _pmul(a: Poly, b: Poly) -> Poly:
    out = [0.0] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] += x * y
    return _ptrim(tuple(out))


def _padd(a: Poly, b: Poly) -> Poly:
    if len(a) < len(b):
        a, b = b, a
    shift = len(a) - len(b)
    return _ptrim(tuple(x + (b[i - shift] if i >= shift else 0.0) for i, x in enumerate(a)))


class Folded:
    """A small polynomial ratio met while compiling; becomes a Rational at the end.  ``typed``:
    a polynomial as it was typed in the monomial basis (sums of constants times powers of the
    variable), whose coefficients are the typed ones: Horner's rule on them is as accurate as
    the typed terms evaluated one by one (both ~ n eps sum |c_i| |x|^i), so such a polynomial is
    folded whatever its degree (an expanded polynomial of degree 8 was dozens of closures)."""

    __slots__ = ("num", "den", "typed")

    def __init__(self, num: Poly, den: Poly, typed: bool = False):
        self.num, self.den, self.typed = num, den, typed

    @property
    def degree(self) -> int:
        return max(len(self.num), len(self.den)) - 1

    @property
    def monomial(self) -> bool:
        return self.den == (1.0,) and sum(c != 0.0 for c in self.num) <= 1

    def combine(self, op: str, other: Folded | None, exponent: int) -> Folded:
        out = self._combined(op, other, exponent)
        out.typed = self._stays_typed(op, other, exponent)
        return out

    def _stays_typed(self, op: str, other: Folded | None, exponent: int) -> bool:
        """Whether ``op`` keeps a typed polynomial's coefficients the typed ones (`Folded`)."""
        if not self.typed or self.den != (1.0,):
            return False
        if op == "neg":
            return True
        if op == "pow":
            return self.monomial and exponent >= 0
        if other is None or not other.typed or other.den != (1.0,):
            return False
        if op in ("add", "sub"):
            return True
        if op == "mul":
            return self.degree == 0 or other.degree == 0 or (self.monomial and other.monomial)
        return other.degree == 0  # divided by a constant

    def _combined(self, op: str, other: Folded | None, exponent: int) -> Folded:
        if op == "neg":
            return Folded(tuple(-c for c in self.num), self.den)
        if op == "pow":
            base = self if exponent >= 0 else Folded(self.den, self.num)
            out = Folded((1.0,), (1.0,))
            for _ in range(abs(exponent)):
                out = Folded(_pmul(out.num, base.num), _pmul(out.den, base.den))
            return out
        if op in ("add", "sub"):
            num = other.num if op == "add" else tuple(-c for c in other.num)
            if self.den == other.den:
                return Folded(_padd(self.num, num), self.den)
            return Folded(_padd(_pmul(self.num, other.den), _pmul(num, self.den)), _pmul(self.den, other.den))
        if op == "mul":
            return Folded(_pmul(self.num, other.num), _pmul(self.den, other.den))
        return Folded(_pmul(self.num, other.den), _pmul(self.den, other.num))

    def rational(self) -> Rational:
        return Rational(np.array(self.num, dtype=float), np.array(self.den, dtype=float))


def _rational_evaluator(r: Rational) -> Evaluator:
    num, den = r.num, r.den
    dnum, dden = np.polyder(num) if num.size > 1 else np.zeros(1), np.polyder(den) if den.size > 1 else np.zeros(1)

    def evaluate(x: NDArray) -> tuple[NDArray, NDArray]:
        n, d = _horner(num, x), _horner(den, x)
        value = n / d
        return value, (_horner(dnum, x) - value * _horner(dden, x)) / d

    return evaluate


def _horner(c: NDArray, x: NDArray) -> NDArray:
    value = np.full(x.shape, c[0], dtype=complex)
    for coefficient in c[1:]:
        value = value * x + coefficient
    return value


def as_callable(c: Folded | Evaluator) -> Evaluator:
    return _rational_evaluator(c.rational()) if isinstance(c, Folded) else c


def constant_subtrees(root: Node) -> dict[int, Folded | Evaluator]:
    """The compiled form of every largest subtree without parameters (by node
    id): compiled once, reused whenever the parameters change."""
    constants: dict[int, Folded | Evaluator] = {}

    def visit(node: Node) -> bool:  # True when the subtree has no parameter
        free = [visit(a) for a in node.args]
        if node.op != "param" and all(free):
            return True
        for arg, is_free in zip(node.args, free):
            if is_free and arg.op not in ("num", "var"):
                constants[id(arg)] = compile_tree(arg, {}, {})
        return False

    if visit(root) and root.op not in ("num", "var"):
        constants[id(root)] = compile_tree(root, {}, {})
    return constants


def compile_tree(
    node: Node, params: Mapping[str, float], constants: dict[int, Folded | Evaluator]
) -> Folded | Evaluator:
    """Fold subtrees of degree <= FOLD_DEGREE into polynomial ratios; keep the
    rest as closures (``constants``: parameter-free subtrees already compiled)."""
    if id(node) in constants:
        return constants[id(node)]
    op = node.op
    if op == "num":
        return Folded((node.value,), (1.0,), typed=True)
    if op == "var":
        return Folded((1.0, 0.0), (1.0,), typed=True)
    if op == "param":
        return Folded((float(params[node.name]),), (1.0,), typed=True)
    args = [compile_tree(a, params, constants) for a in node.args]
    if all(isinstance(a, Folded) for a in args):
        folded = args[0].combine(op, args[1] if len(args) > 1 else None, node.exponent)
        if folded.degree <= FOLD_DEGREE or folded.typed:
            return folded
    f = [as_callable(a) for a in args]
    if op == "neg":
        return lambda x: tuple(-v for v in f[0](x))
    if op == "pow":
        k = node.exponent

        def power(x):
            v, dv = f[0](x)
            return v**k, k * v ** (k - 1) * dv if k != 0 else 0 * dv

        return power
    return _binary(op, f[0], f[1])


def _binary(op: str, f, g) -> Evaluator:
    def evaluate(x):
        (a, da), (b, db) = f(x), g(x)
        if op == "add":
            return a + b, da + db
        if op == "sub":
            return a - b, da - db
        if op == "mul":
            return a * b, da * b + a * db
        q = a / b
        return q, (da - q * db) / b

    return evaluate

"""An expression's text as a product: its top-level factors over and under the line, each
kept as it was typed, and the text of a product of factors; and the one writer of factor
text from roots (`root_factors`: a real root's (x - r), a conjugate pair's real quadratic).  This is how a compensator
gains a part (a lead, a notch) or loses one of its factors without being rewritten:
``K*(1+T1*s)/((1+T2*s)*(1+T3*s))`` is ``K``, ``1+T1*s`` over ``1+T2*s``, ``1+T3*s``."""

from __future__ import annotations

import ast
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from engine.errors import ExpressionError

PAIRING = 1e-9  # a root above the axis and one below within this of its size are a conjugate pair


@dataclass(frozen=True)
class Product:
    """An expression as factors over and under the line (texts as typed)."""

    numerator: tuple[str, ...]
    denominator: tuple[str, ...]

    @property
    def text(self) -> str:
        """'K*(1+T1*s)/((1+T2*s)*(1+T3*s))'; '1' for no factors."""
        over = "*".join(_bracketed(f) for f in self.numerator) or "1"
        if not self.denominator:
            return over
        under = (
            _bracketed(self.denominator[0])
            if len(self.denominator) == 1
            else f"({'*'.join(map(_bracketed, self.denominator))})"
        )
        return f"{over}/{under}"

    def times(self, other: Product) -> Product:
        return Product(self.numerator + other.numerator, self.denominator + other.denominator)

    def without(self, over: int | None = None, under: int | None = None) -> Product:
        """The product without numerator factor ``over`` or denominator factor ``under``."""
        return Product(
            tuple(f for k, f in enumerate(self.numerator) if k != over),
            tuple(f for k, f in enumerate(self.denominator) if k != under),
        )


def product(text: str) -> Product:
    """The top-level factors of an expression (``^`` read as a power)."""
    source = text.replace("^", "**")
    try:
        tree = ast.parse(source, mode="eval").body
    except SyntaxError as exc:
        raise ExpressionError(f"{text!r} does not read as an expression: {exc.msg}") from None
    over: list[str] = []
    under: list[str] = []
    _split(tree, source, over, under, True)
    return Product(tuple(over), tuple(under))


def _split(node: ast.expr, source: str, over: list[str], under: list[str], up: bool) -> None:
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
        _split(node.left, source, over, under, up)
        _split(node.right, source, over, under, up if isinstance(node.op, ast.Mult) else not up)
        return
    text = ast.get_source_segment(source, node).replace("**", "^")
    (over if up else under).append(text)


def _bracketed(factor: str) -> str:
    """A factor as it may stand in a product: bracketed unless it is one name, number or
    power of a bracketed or plain term."""
    try:
        node = ast.parse(factor.replace("^", "**"), mode="eval").body
    except SyntaxError:
        return f"({factor})"
    simple = isinstance(node, (ast.Name, ast.Constant)) or (
        isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow)
    )
    return factor if simple else f"({factor})"


def root_factors(roots: Sequence[complex] | np.ndarray, variable: str, exact: bool = True) -> list[str]:
    """prod(x - r) as factor texts, in the roots' order: a real root's (x - r) (x alone at 0
    when not ``exact``), a conjugate pair's real quadratic x^2 - 2 Re(r) x + |r|^2 once, at its
    first root.  A root above the axis and one below pair within `PAIRING` of its size; a
    complex root without a mirror image stands for a real root (the roots of a real polynomial
    come in pairs: a lone one is a real root rounded off the axis), written by its real part,
    so the factors hold as many roots as were given.  ``exact``: every
    number written as its shortest round-trip text, to be read back as an expression
    ('(z^2-(1.2)*z+(0.52))'); else to six digits, for reading ('(s^2 + 1.2 s + 0.52)')."""
    roots = np.asarray(roots, dtype=complex)
    used, out = np.zeros(roots.size, dtype=bool), []
    for i, r in enumerate(roots.tolist()):
        if used[i]:
            continue
        used[i] = True
        mirror = next((j for j in range(i + 1, roots.size) if not used[j] and _mirrors(roots[j], r)), None)
        if r.imag == 0 or mirror is None:
            out.append(_linear(r.real, variable, exact))
            continue
        used[mirror] = True
        out.append(_quadratic(-2.0 * r.real, abs(r) ** 2, variable, exact))
    return out


def time_constant_factor(root: complex, variable: str, pair: bool) -> str:
    """One root's factor in time-constant form, for reading: (1 + x/0.667) for a real root at
    -0.667 ('-' in the right half-plane), x at 0, and for a pair (by either of its roots)
    (1 + 2 zeta x/wn + (x/wn)^2), 2 zeta = -2 Re(r)/wn signed."""
    x, w = variable, abs(root)
    if w == 0:
        return x
    if pair:
        return f"(1 + {-2 * root.real / w:.6g}*{x}/{w:.6g} + ({x}/{w:.6g})^2)"
    return f"(1 {'-' if root.real > 0 else '+'} {x}/{w:.6g})"


def _mirrors(a: complex, b: complex) -> bool:
    """Are ``a`` and ``b`` a conjugate pair (off the axis, within `PAIRING`)?"""
    return a.imag * b.imag < 0 and abs(a - b.conjugate()) <= PAIRING * abs(b)


def _linear(root: float, x: str, exact: bool) -> str:
    if exact:
        return f"({x}-({float(root)!r}))"
    return x if root == 0 else f"({x} {_signed(-root)})"


def _quadratic(b: float, c: float, x: str, exact: bool) -> str:
    if exact:
        return f"({x}^2-({float(-b)!r})*{x}+({float(c)!r}))"
    return f"({x}^2 {_signed(b)} {x} + {c:.6g})"


def _signed(value: float) -> str:
    return f"{'-' if value < 0 else '+'} {abs(value):.6g}"

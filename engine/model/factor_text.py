"""An expression's text as a product: its top-level factors over and under the line, each
kept as it was typed, and the text of a product of factors.  This is how a compensator
gains a part (a lead, a notch) or loses one of its factors without being rewritten:
``K*(1+T1*s)/((1+T2*s)*(1+T3*s))`` is ``K``, ``1+T1*s`` over ``1+T2*s``, ``1+T3*s``."""

from __future__ import annotations

import ast
from dataclasses import dataclass

from engine.errors import ExpressionError


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

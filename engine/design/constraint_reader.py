"""A reader of linear inequalities between parameters, e.g. ``T1 >= 4*T2``.

Accepted: one comparison ``<=`` or ``>=`` between two linear forms in parameter
names; numbers (``2``, ``0.5``, ``1e-3``), names, ``name[condition]`` (one
condition's value of a per-condition parameter: its name or index), ``+ - * /``,
parentheses and integer powers (``**`` or ``^``) of numbers.  A product or
quotient must leave at most one factor that holds a parameter, and a divisor
must be a number: ``K*T1 <= 10`` and ``1/T2 >= 3`` are refused as not linear.
The text is read by a small recursive-descent parser, never by Python's eval,
and the arithmetic is exact (fractions of the decimal numbers as written):
``0.1*3*T1`` has the coefficient 0.3, the float nearest 3/10.  Every error is a
`LinearFormError` giving the 1-based column of the offending token.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache

from engine.errors import ExpressionError

MAX_LENGTH = 1000  # characters of one constraint
MAX_NESTING = 50  # levels of parentheses (and unary signs)
MAX_POWER = 64
MAX_BITS = 4000  # of a number's numerator or denominator while reading (beyond: not a float)
COMPARISONS = ("<=", ">=")
TOKEN = re.compile(
    r"\s*(?:(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_]\w*)"
    r"|(?P<label>\[[^\[\]]*\])|(?P<op><=|>=|=<|=>|==|\*\*|[-+*/^()<>=]))"
)


class LinearFormError(ExpressionError):
    """A constraint that is not a linear inequality; ``position``: the 0-based column."""


@dataclass(frozen=True)
class Reference:
    """A parameter as a constraint names it: ``name``, or ``name[label]`` (label: a condition)."""

    name: str
    label: str | None = None

    def __str__(self) -> str:
        return self.name if self.label is None else f"{self.name}[{self.label}]"


@dataclass(frozen=True)
class LinearForm:
    """``sum(coefficient * reference) <= bound``, whatever the sense written: a ``>=``
    is stored negated.  ``text``: the constraint as written."""

    terms: tuple[tuple[Reference, float], ...]
    bound: float
    text: str


@dataclass(frozen=True)
class _Token:
    kind: str  # number, name, label, op, end
    text: str
    column: int


Affine = tuple[dict[Reference, Fraction], Fraction]  # coefficients and the constant
ONE, ZERO = Fraction(1), Fraction(0)


def read_constraint(text: str) -> LinearForm:
    """The linear form of one constraint line, or a `LinearFormError` with its column."""
    if not isinstance(text, str):
        raise LinearFormError(f"a constraint is text, not {type(text).__name__}")
    if not text.strip():
        raise LinearFormError("empty constraint (write e.g. 'T1 >= 4*T2')")
    if len(text) > MAX_LENGTH:
        raise LinearFormError(f"a constraint has at most {MAX_LENGTH} characters, not {len(text)}")
    return _read(text)


@lru_cache(maxsize=4096)
def _read(text: str) -> LinearForm:
    """The form of a line (immutable: a session's schema check and its build read it once)."""
    return _Reader(text).constraint()


def _tokens(text: str) -> list[_Token]:
    """The tokens of a line (an unknown character is an error at its column)."""
    out, at = [], 0
    while at < len(text):
        match = TOKEN.match(text, at)
        if match is None or match.end() == at:
            if not text[at:].strip():
                break
            column = len(text) - len(text[at:].lstrip())
            raise LinearFormError(f"unexpected character {text[column]!r}", text, column)
        kind = match.lastgroup or "op"
        out.append(_Token(kind, match.group(kind), match.start(kind)))
        at = match.end()
    out.append(_Token("end", "", len(text)))
    return out


class _Reader:
    """side (<= | >=) side, each side a sum of terms; exact arithmetic on `Fraction`s."""

    def __init__(self, text: str):
        self.text, self.tokens, self.at, self.depth = text, _tokens(text), 0, 0

    def _peek(self) -> _Token:
        return self.tokens[self.at]

    def _next(self) -> _Token:
        token = self.tokens[self.at]
        self.at = min(self.at + 1, len(self.tokens) - 1)
        return token

    def _fail(self, message: str, token: _Token) -> LinearFormError:
        return LinearFormError(message, self.text, token.column)  # the end: one past the last character

    def constraint(self) -> LinearForm:
        left = self._sum()
        op = self._next()
        if op.text not in COMPARISONS:
            raise self._comparison_error(op)
        right = self._sum()
        end = self._next()
        if end.kind != "end":
            raise self._fail(
                "one comparison per constraint (write two constraints)"
                if end.text in COMPARISONS
                else f"unexpected {end.text!r} (a missing operator?)",
                end,
            )
        sign = 1 if op.text == "<=" else -1
        terms = {ref: sign * (left[0].get(ref, 0) - right[0].get(ref, 0)) for ref in {**left[0], **right[0]}}
        terms = {ref: c for ref, c in terms.items() if c != 0}
        if not terms:
            raise self._fail("no parameter left once the terms are collected: the constraint compares numbers", op)
        bound = sign * (right[1] - left[1])
        return LinearForm(
            tuple((ref, self._float(c, op)) for ref, c in terms.items()), self._float(bound, op), self.text
        )

    def _comparison_error(self, op: _Token) -> LinearFormError:
        if op.kind == "end":
            return self._fail("no comparison: write '<=' or '>=' between two linear forms", op)
        if op.text in ("<", ">"):
            return self._fail(f"strict {op.text!r}: write '{op.text}=' (an optimizer holds the boundary)", op)
        if op.text in ("=", "=="):
            return self._fail("an equality: write it in problem.equalities, or use '<=' / '>='", op)
        if op.text in ("=<", "=>"):
            return self._fail(f"write {op.text[::-1]!r}, not {op.text!r}", op)
        return self._fail(f"unexpected {op.text!r} (a missing operator? products are written with '*')", op)

    def _float(self, value: Fraction, token: _Token) -> float:
        try:
            return float(value)
        except OverflowError:
            raise self._fail("a coefficient is beyond floating point", token) from None

    def _sum(self) -> Affine:
        total = self._product()
        while self._peek().text in ("+", "-"):
            sign = 1 if self._next().text == "+" else -1
            terms, constant = self._product()
            merged = dict(total[0])
            for ref, c in terms.items():
                merged[ref] = merged.get(ref, 0) + sign * c
            total = (merged, total[1] + sign * constant)
        return total

    def _product(self) -> Affine:
        value = self._unary()
        while self._peek().text in ("*", "/"):
            op = self._next()
            other = self._unary()
            value = self._times(value, other, op) if op.text == "*" else self._divided(value, other, op)
        return value

    def _times(self, a: Affine, b: Affine, op: _Token) -> Affine:
        if a[0] and b[0]:
            names = " and ".join(str(next(iter(side[0]))) for side in (a, b))
            raise self._fail(f"not linear: a product of parameters ({names})", op)
        scale, form = (a[1], b) if not a[0] else (b[1], a)
        return self._checked(({ref: scale * c for ref, c in form[0].items()}, scale * form[1]), op)

    def _divided(self, a: Affine, b: Affine, op: _Token) -> Affine:
        if b[0]:
            raise self._fail(f"not linear: division by parameter {next(iter(b[0]))}", op)
        if b[1] == 0:
            raise self._fail("division by zero", op)
        return self._checked(({ref: c / b[1] for ref, c in a[0].items()}, a[1] / b[1]), op)

    def _unary(self) -> Affine:
        token = self._peek()
        if token.text not in ("+", "-"):
            return self._power()
        self._next()
        self._enter(token)
        terms, constant = self._unary()
        self.depth -= 1
        return (terms, constant) if token.text == "+" else ({r: -c for r, c in terms.items()}, -constant)

    def _power(self) -> Affine:
        base = self._atom()
        if self._peek().text not in ("**", "^"):
            return base
        op = self._next()
        if base[0]:
            raise self._fail(f"not linear: a power of parameter {next(iter(base[0]))}", op)
        sign, token = 1, self._next()
        if token.text in ("+", "-"):
            sign, token = (1 if token.text == "+" else -1), self._next()
        if token.kind != "number" or not Fraction(token.text).denominator == 1:
            raise self._fail("an exponent is an integer", token)
        exponent = sign * int(Fraction(token.text))
        if abs(exponent) > MAX_POWER:
            raise self._fail(f"an exponent is at most {MAX_POWER} in size", token)
        if base[1] == 0 and exponent < 0:
            raise self._fail("division by zero", op)
        return self._checked(({}, base[1] ** exponent), op)

    def _atom(self) -> Affine:
        token = self._next()
        if token.kind == "number":
            return self._checked(({}, self._number(token)), token)
        if token.kind == "name":
            label = None
            if self._peek().kind == "label":
                label = self._next().text[1:-1].strip()
                if not label:
                    raise self._fail(f"empty condition in {token.text}[]", token)
            return {Reference(token.text, label): ONE}, ZERO
        if token.text == "(":
            self._enter(token)
            inner = self._sum()
            self.depth -= 1
            close = self._next()
            if close.text != ")":
                raise self._fail("a ')' is missing", close)
            return inner
        if token.kind == "label":
            raise self._fail("a condition in brackets follows a parameter's name", token)
        what = "end of the constraint" if token.kind == "end" else repr(token.text)
        raise self._fail(f"a number, a parameter or '(' expected, not {what}", token)

    def _number(self, token: _Token) -> Fraction:
        exponent = token.text.lower().partition("e")[2]
        if exponent and abs(int(exponent)) > 1000:
            raise self._fail(f"number {token.text} is beyond floating point", token)
        return Fraction(token.text)

    def _enter(self, token: _Token) -> None:
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise self._fail(f"nested more than {MAX_NESTING} levels deep", token)

    def _checked(self, value: Affine, token: _Token) -> Affine:
        """A value whose numbers stay within what a float can hold (bounded work)."""
        for number in (*value[0].values(), value[1]):
            if number.numerator.bit_length() > MAX_BITS or number.denominator.bit_length() > MAX_BITS:
                raise self._fail("a number is beyond floating point", token)
        return value

"""A safe parser for transfer-function and parameter expressions.

Grammar: numbers, names, + - * /, integer powers (``**`` or ``^``) and
parentheses, read with Python's ``ast`` module and never evaluated by Python.
One name is the frequency variable (``s``, ``w`` or ``z``); every other name
is a parameter.  An expression evaluates to

* a complex response with forward-mode derivatives with respect to each
  parameter and to the variable (`Expression.evaluate`), vectorized over any
  array of variable values, or
* a `Rational` (polynomial ratio) for given parameter values
  (`Expression.rational`).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from engine.derived import Derived, Form
from engine.errors import ExpressionError, ParameterError, shortened
from engine.model.folding import (
    FOLD_DEGREE,
    Evaluator,
    Folded,
    as_callable,
    compile_tree,
    constant_subtrees,
    to_rational,
)
from engine.numerics.polynomials import Rational

VARIABLES = ("s", "w", "z")
MAX_POWER = 64
MAX_LENGTH = 10_000
MAX_DEPTH = 100  # levels of nesting after long chains are balanced: every walk of a tree recurses
T = TypeVar("T")
COMPILED: Form[Folded | Evaluator] = Form("compiled")  # `compile_tree`'s, at some parameter values
RATIONAL: Form[Rational] = Form("rational")
CHAIN = 64  # a longer run of + - (or * /) is balanced, a shorter one kept as Python reads it


@dataclass(frozen=True)
class Node:
    """One node of the restricted expression tree."""

    op: str  # "num", "var", "param", "add", "sub", "mul", "div", "neg", "pow"
    args: tuple[Node, ...] = ()
    value: float = 0.0
    name: str = ""
    exponent: int = 0


@dataclass
class Dual:
    """A value with derivatives: d/dparameter for some parameters, and d/dvariable."""

    value: NDArray[np.complex128]
    grad: dict[str, NDArray[np.complex128]] = field(default_factory=dict)
    dvar: NDArray[np.complex128] | None = None

    def _combine(self, other: Dual, da, db) -> tuple[dict, NDArray | None]:
        grad: dict[str, NDArray] = {}
        for name, g in self.grad.items():
            grad[name] = da * g
        for name, g in other.grad.items():
            grad[name] = grad[name] + db * g if name in grad else db * g
        dvar = None
        if self.dvar is not None or other.dvar is not None:
            dvar = 0
            if self.dvar is not None:
                dvar = dvar + da * self.dvar
            if other.dvar is not None:
                dvar = dvar + db * other.dvar
        return grad, dvar

    def add(self, other: Dual, sign: float = 1.0) -> Dual:
        grad, dvar = self._combine(other, 1.0, sign)
        return Dual(self.value + sign * other.value, grad, dvar)

    def mul(self, other: Dual) -> Dual:
        grad, dvar = self._combine(other, other.value, self.value)
        return Dual(self.value * other.value, grad, dvar)

    def div(self, other: Dual) -> Dual:
        reciprocal = 1.0 / other.value  # one complex division; products are much cheaper
        quotient = self.value * reciprocal
        grad, dvar = self._combine(other, reciprocal, -quotient * reciprocal)
        return Dual(quotient, grad, dvar)

    def power(self, k: int) -> Dual:
        if k == 0:
            return Dual(np.complex128(1.0))
        scale = k * self.value ** (k - 1)
        grad = {name: scale * g for name, g in self.grad.items()}
        dvar = None if self.dvar is None else scale * self.dvar
        return Dual(self.value**k, grad, dvar)


class Expression:
    """A parsed expression in one frequency variable and named parameters."""

    def __init__(self, text: str, variable: str = "s"):
        if variable not in VARIABLES:
            raise ExpressionError(f"variable must be one of {VARIABLES}, not {variable!r}")
        self.text = text
        self.variable = variable
        read = _read if isinstance(text, str) else _read.__wrapped__  # the parser names a non-text
        self.root, self.parameters, self._constants = read(text, variable)
        self.derived = Derived()  # forms at the last few parameter values (rational forms are reused a lot)

    def at(self, form: Form[T], params: Mapping[str, float], make: Callable[[], T]) -> T:
        """The expression's ``form`` at the parameter values ``params``, made once (`self.derived`)."""
        self._check_params(params)
        return self.derived.get(form, make, *(float(params[p]) for p in self.parameters))

    def __repr__(self) -> str:
        return f"Expression({self.text!r}, variable={self.variable!r})"

    def evaluate(
        self, x: NDArray[np.complex128], params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        """Value at every point of ``x`` with derivatives w.r.t. every parameter
        (none formed when not ``with_grad``)."""
        self._check_params(params)
        x = np.asarray(x, dtype=complex)
        with np.errstate(divide="ignore", invalid="ignore"):
            dual = _evaluate(self.root, x, params, with_dvar, with_grad)
        return _broadcast(dual, x.shape, with_dvar)

    def fraction(self, x: NDArray[np.complex128], params: Mapping[str, float]) -> tuple[Dual, Dual]:
        """The numerator and the denominator at every point of ``x`` as the tree writes them
        (nothing cancelled: (a/b)/(c/d) is (a d)/(b c)), each with its derivatives w.r.t. every
        parameter and the variable: finite at a pole, where `evaluate` divides by zero."""
        self._check_params(params)
        x = np.asarray(x, dtype=complex)
        with np.errstate(all="ignore"):
            num, den = _fraction(self.root, x, params)
        return _broadcast(num, x.shape, True), _broadcast(den, x.shape, True)

    def compile(self, params: Mapping[str, float]) -> Evaluator:
        """A fast evaluator of (value, d/dvariable) for fixed parameter values.

        Subtrees of low degree are folded into small polynomial ratios
        (evaluated by Horner's rule); larger products stay products, so the
        accuracy of a factored form is kept.
        """
        return as_callable(self._compiled(params))

    def folded(self, params: Mapping[str, float]) -> Rational | None:
        """The expression as a polynomial ratio of degree <= FOLD_DEGREE, else None."""
        compiled = self._compiled(params)
        return compiled.rational() if isinstance(compiled, Folded) and compiled.degree <= FOLD_DEGREE else None

    def rational(self, params: Mapping[str, float]) -> Rational:
        """The expression as a ratio of polynomials in the variable."""
        return self.at(RATIONAL, params, lambda: to_rational(self.root, params))

    def _compiled(self, params: Mapping[str, float]) -> Folded | Evaluator:
        return self.at(COMPILED, params, lambda: compile_tree(self.root, params, self._constants))

    def value(self, params: Mapping[str, float]) -> float:
        """Evaluate a parameter expression that does not contain the variable."""
        r = self.rational(params)
        if r.num.size > 1 or r.den.size > 1:
            raise ExpressionError(f"expression depends on {self.variable!r}", self.text)
        if r.den[0] == 0.0:
            raise ExpressionError("division by zero", self.text)
        return float(r.num[0] / r.den[0])

    def _check_params(self, params: Mapping[str, float]) -> None:
        missing = [p for p in self.parameters if p not in params]
        if missing:
            raise ParameterError(f"no value for parameter(s) {', '.join(missing)} in {self.text!r}")


@lru_cache(maxsize=256)
def _read(text: str, variable: str) -> tuple[Node, tuple[str, ...], dict]:
    """A text's tree, its parameters and its compiled parameter-free subtrees
    (immutable once made, so expressions of the same text share them)."""
    root = _Parser(text, variable).parse()
    return root, tuple(sorted(_collect_parameters(root))), constant_subtrees(root)


class _Chain:
    """A run of one precedence level met while converting (a + b - c ..., a * b / c ...):
    long runs become balanced trees, so a long sum is not a deep one."""

    __slots__ = ("kind", "terms")

    def __init__(self, kind: str, terms: list[tuple[str, Node]]):
        self.kind, self.terms = kind, terms


OPS = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div"}
INVERSE = {"add": "sub", "sub": "add", "mul": "div", "div": "mul"}


def _finish(item: Node | _Chain) -> Node:
    """A node; a chain as the left-deep tree Python reads, or balanced when it is long."""
    if isinstance(item, Node):
        return item
    terms = item.terms
    if len(terms) > CHAIN:
        return _balanced(terms)
    acc = terms[0][1]
    for op, term in terms[1:]:
        acc = Node(op, (acc, term))
    return acc


def _balanced(terms: list[tuple[str, Node]]) -> Node:
    """t0 op1 t1 op2 t2 ... as a tree of depth log2(n): L + (-a + b) is L - (a - b)."""
    if len(terms) == 1:
        return terms[0][1]
    half = len(terms) // 2
    left, right = _balanced(terms[:half]), terms[half:]
    op = right[0][0]
    if op in ("sub", "div"):
        right = [(INVERSE[o], t) for o, t in right]
    return Node(op, (left, _balanced(right)))


def _depth(root: Node) -> int:
    """The depth of a tree, without recursion."""
    deepest, stack = 0, [(root, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((arg, depth + 1) for arg in node.args)
    return deepest


def substituted(text: str, name: str, replacement: str) -> str:
    """An expression's text with every use of the name ``name`` (the variable or a parameter)
    replaced by ``replacement`` (parenthesized by the caller): a name as the parser reads one,
    not part of a longer name or of a number."""
    return re.sub(rf"(?<![\w.]){re.escape(name)}(?!\w)", lambda _: replacement, text)


# a number written directly before a name (0.5s, 2T1): a product without its '*'
NUMBER_AGAINST_NAME = re.compile(r"(?<![\w.])(\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)([A-Za-z_]\w*)")


class _Parser:
    """Translate Python's ast into `Node`s, refusing everything else (without
    recursion: a long chain of operators makes a deep ast)."""

    def __init__(self, text: str, variable: str):
        self.text = text
        self.variable = variable

    def parse(self) -> Node:
        if not isinstance(self.text, str) or not self.text.strip():
            raise ExpressionError("empty expression", str(self.text))
        if len(self.text) > MAX_LENGTH:
            raise ExpressionError(f"expression longer than {MAX_LENGTH} characters", shortened(self.text, 43))
        # '^' means power; Python would read it as xor with a lower precedence than '+'
        self.carets = [i for i, ch in enumerate(self.text) if ch == "^"]
        source = self.text.replace("^", "**")
        try:
            tree = ast.parse(source, mode="eval")
        except SyntaxError as exc:
            raise self._syntax_error(source, exc) from None
        except (RecursionError, MemoryError):
            raise ExpressionError("expression nested too deeply to read", self.text) from None
        except ValueError:
            raise ExpressionError("expression cannot be read (a null character?)", self.text) from None
        root = self._convert(tree.body)
        if _depth(root) > MAX_DEPTH:
            raise ExpressionError(f"expression nested more than {MAX_DEPTH} levels deep", self.text)
        return root

    def _syntax_error(self, source: str, exc: SyntaxError) -> ExpressionError:
        """What does not read, said where it is: Python points at the start of an unfinished
        expression, so a dangling operator and a number written against a name are found first."""
        text = self.text.rstrip()
        if text and text[-1] in "+-*/^(":
            return ExpressionError(f"{text[-1]!r} at the end has nothing after it", self.text, len(text) - 1)
        glued = NUMBER_AGAINST_NAME.search(self.text)
        if glued is not None:
            number, name = glued.group(1), glued.group(2)
            return ExpressionError(
                f"a number against a name: write {number}*{name} for a product", self.text, glued.start(2)
            )
        col = self._original_column(source, (exc.offset or 1) - 1)
        token = self.text[col : col + 1] if col < len(self.text) else "end of input"
        reason = exc.msg.removeprefix("invalid syntax").strip(" .") or "invalid syntax"
        if "forgot a comma" in reason:
            reason = "a missing operator (write '*' for products)"
        return ExpressionError(f"{reason} near {token!r}", self.text, col)

    def _original_column(self, source: str, col: int) -> int:
        """Map a column of the '^'-rewritten source back to the user's text."""
        before = sum(1 for i in self.carets if i + self.carets.index(i) < col)
        return max(0, min(col - before, len(self.text)))

    def _fail(self, message: str, node: ast.AST) -> ExpressionError:
        col = getattr(node, "col_offset", None)
        col = None if col is None else self._original_column(self.text.replace("^", "**"), col)
        return ExpressionError(message, self.text, col)

    def _convert(self, root: ast.AST) -> Node:
        """The ast in post-order with an explicit stack."""
        built: dict[int, Node | _Chain] = {}
        stack = [(root, False)]
        while stack:
            node, ready = stack.pop()
            children = self._children(node)
            if not ready:
                stack.append((node, True))
                stack.extend((child, False) for child in children)
                continue
            built[id(node)] = self._build(node, [built.pop(id(child)) for child in children])
        return _finish(built[id(root)])

    def _children(self, node: ast.AST) -> list[ast.AST]:
        """The operands to convert first; anything outside the grammar is refused here."""
        if isinstance(node, (ast.Constant, ast.Name)):
            return []
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            return [node.operand]
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, (ast.Pow, ast.BitXor)):
                return [node.left]
            if type(node.op) in OPS:
                return [node.left, node.right]
            raise self._fail(f"unsupported operator {type(node.op).__name__!r}", node)
        if isinstance(node, ast.Call):
            source = self.text.replace("^", "**")
            col = source.find("(", getattr(node.func, "end_col_offset", node.col_offset))
            col = self._original_column(source, col if col >= 0 else node.col_offset)
            raise ExpressionError("function calls are not allowed (a '*' missing before '('?)", self.text, col)
        token = type(node).__name__
        raise self._fail(f"unsupported element {token!r} (only numbers, names, + - * / ** and parentheses)", node)

    def _build(self, node: ast.AST, args: list[Node | _Chain]) -> Node | _Chain:
        """One node from its converted operands."""
        if isinstance(node, ast.Constant):
            return self._number(node)
        if isinstance(node, ast.Name):
            if node.id == self.variable:
                return Node("var")
            if node.id in VARIABLES:
                raise self._fail(f"variable {node.id!r} in an expression in {self.variable!r}", node)
            return Node("param", name=node.id)
        if isinstance(node, ast.UnaryOp):
            operand = _finish(args[0])
            if isinstance(node.op, ast.UAdd):
                return operand
            return operand.args[0] if operand.op == "neg" else Node("neg", (operand,))  # --x is x
        if len(args) == 1:
            return Node("pow", (_finish(args[0]),), exponent=self._integer_exponent(node.right))
        op = OPS[type(node.op)]
        kind = "sum" if op in ("add", "sub") else "product"
        left, right = args[0], _finish(args[1])
        if isinstance(left, _Chain) and left.kind == kind:
            left.terms.append((op, right))
            return left
        return _Chain(kind, [("add" if kind == "sum" else "mul", _finish(left)), (op, right)])

    def _number(self, node: ast.Constant) -> Node:
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise self._fail(f"unsupported constant {node.value!r}", node)
        try:
            value = float(node.value)
        except OverflowError:
            value = float("inf")
        if not np.isfinite(value):
            raise self._fail("non-finite number", node)
        return Node("num", value=value)

    def _integer_exponent(self, node: ast.AST) -> int:
        sign = 1
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            sign = -1 if isinstance(node.op, ast.USub) else 1
            node = node.operand
        value = getattr(node, "value", None) if isinstance(node, ast.Constant) else None
        integral = isinstance(value, int) or (isinstance(value, float) and value.is_integer())
        if isinstance(value, bool) or not integral:
            raise self._fail("exponent must be an integer constant", node)
        exponent = sign * int(value)
        if abs(exponent) > MAX_POWER:
            shown = exponent if abs(exponent) < 10**12 else f"{'-' if exponent < 0 else ''}{str(abs(exponent))[:6]}..."
            raise self._fail(f"exponent {shown} exceeds {MAX_POWER}", node)
        return exponent


def _collect_parameters(node: Node) -> set[str]:
    names = {node.name} if node.op == "param" else set()
    for arg in node.args:
        names |= _collect_parameters(arg)
    return names


def _broadcast(dual: Dual, shape: tuple[int, ...], with_dvar: bool) -> Dual:
    """Constants and parameters evaluate to scalars; give every part the full shape."""

    def full(v) -> NDArray:
        return v if np.shape(v) == shape else np.full(shape, v, dtype=complex)

    dvar = full(0.0 if dual.dvar is None else dual.dvar) if with_dvar else None
    return Dual(full(dual.value), {k: full(g) for k, g in dual.grad.items()}, dvar)


def _evaluate(node: Node, x: NDArray, params: Mapping[str, float], with_dvar: bool, with_grad: bool = True) -> Dual:
    """Forward-mode evaluation; subtrees free of the variable stay scalars."""
    op = node.op
    if op == "num":
        return Dual(np.complex128(node.value))
    if op == "var":
        return Dual(x, {}, 1.0 if with_dvar else None)
    if op == "param":
        return Dual(np.complex128(float(params[node.name])), {node.name: 1.0} if with_grad else {})
    args = [_evaluate(a, x, params, with_dvar, with_grad) for a in node.args]
    if op == "neg":
        return args[0].mul(Dual(np.complex128(-1.0)))
    if op == "pow":
        return args[0].power(node.exponent)
    if op == "add":
        return args[0].add(args[1])
    if op == "sub":
        return args[0].add(args[1], -1.0)
    if op == "mul":
        return args[0].mul(args[1])
    return args[0].div(args[1])


def _fraction(node: Node, x: NDArray, params: Mapping[str, float]) -> tuple[Dual, Dual]:
    """`Expression.fraction` of a subtree: (numerator, denominator), forward mode."""
    if not node.args:
        return _evaluate(node, x, params, True), Dual(np.complex128(1.0))
    (n, d), *rest = [_fraction(a, x, params) for a in node.args]
    if node.op == "neg":
        return n.mul(Dual(np.complex128(-1.0))), d
    if node.op == "pow":
        k = node.exponent
        return (n.power(k), d.power(k)) if k >= 0 else (d.power(-k), n.power(-k))
    m, e = rest[0]
    if node.op == "mul":
        return n.mul(m), d.mul(e)
    if node.op == "div":
        return n.mul(e), d.mul(m)
    return n.mul(e).add(m.mul(d), 1.0 if node.op == "add" else -1.0), d.mul(e)

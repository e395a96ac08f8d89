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
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .errors import ExpressionError, ParameterError
from .polynomials import Rational

VARIABLES = ("s", "w", "z")
MAX_POWER = 64


@dataclass(frozen=True)
class Node:
    """One node of the restricted expression tree."""

    op: str  # "num", "var", "param", "add", "sub", "mul", "div", "neg", "pow"
    args: tuple["Node", ...] = ()
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
        quotient = self.value / other.value
        grad, dvar = self._combine(other, 1.0 / other.value, -quotient / other.value)
        return Dual(quotient, grad, dvar)

    def power(self, k: int) -> Dual:
        if k == 0:
            return Dual(np.ones_like(self.value))
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
        self.root = _Parser(text, variable).parse()
        self.parameters: tuple[str, ...] = tuple(sorted(_collect_parameters(self.root)))

    def __repr__(self) -> str:
        return f"Expression({self.text!r}, variable={self.variable!r})"

    def evaluate(
        self, x: NDArray[np.complex128], params: Mapping[str, float], with_dvar: bool = False
    ) -> Dual:
        """Value at every point of ``x`` with derivatives w.r.t. every parameter."""
        self._check_params(params)
        with np.errstate(divide="ignore", invalid="ignore"):
            return _evaluate(self.root, np.asarray(x, dtype=complex), params, with_dvar)

    def rational(self, params: Mapping[str, float]) -> Rational:
        """The expression as a ratio of polynomials in the variable."""
        self._check_params(params)
        return _to_rational(self.root, params)

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


class _Parser:
    """Translate Python's ast into `Node`s, refusing everything else."""

    def __init__(self, text: str, variable: str):
        self.text = text
        self.variable = variable

    def parse(self) -> Node:
        if not isinstance(self.text, str) or not self.text.strip():
            raise ExpressionError("empty expression", str(self.text))
        try:
            tree = ast.parse(self.text.strip(), mode="eval")
        except SyntaxError as exc:
            col = (exc.offset or 1) - 1
            token = self.text.strip()[col:col + 1] if col < len(self.text.strip()) else "end of input"
            reason = exc.msg.removeprefix("invalid syntax").strip(" .") or "invalid syntax"
            raise ExpressionError(f"{reason} near {token!r}", self.text, col) from None
        return self._node(tree.body)

    def _fail(self, message: str, node: ast.AST) -> ExpressionError:
        return ExpressionError(message, self.text, getattr(node, "col_offset", None))

    def _node(self, node: ast.AST) -> Node:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise self._fail(f"unsupported constant {node.value!r}", node)
            if not np.isfinite(node.value):
                raise self._fail("non-finite number", node)
            return Node("num", value=float(node.value))
        if isinstance(node, ast.Name):
            if node.id == self.variable:
                return Node("var")
            if node.id in VARIABLES:
                raise self._fail(f"variable {node.id!r} in an expression in {self.variable!r}", node)
            return Node("param", name=node.id)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = self._node(node.operand)
            return Node("neg", (operand,)) if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            return self._binop(node)
        if isinstance(node, ast.Call):
            col = getattr(node.func, "end_col_offset", node.col_offset)
            raise ExpressionError("function calls are not allowed (a '*' missing before '('?)", self.text, col)
        token = type(node).__name__
        raise self._fail(f"unsupported element {token!r} (only numbers, names, + - * / ** and parentheses)", node)

    def _binop(self, node: ast.BinOp) -> Node:
        ops = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div"}
        if isinstance(node.op, (ast.Pow, ast.BitXor)):
            return Node("pow", (self._node(node.left),), exponent=self._integer_exponent(node.right))
        if type(node.op) not in ops:
            raise self._fail(f"unsupported operator {type(node.op).__name__!r}", node)
        return Node(ops[type(node.op)], (self._node(node.left), self._node(node.right)))

    def _integer_exponent(self, node: ast.AST) -> int:
        sign = 1
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            sign = -1 if isinstance(node.op, ast.USub) else 1
            node = node.operand
        if not (isinstance(node, ast.Constant) and isinstance(node.value, (int, float))
                and not isinstance(node.value, bool) and float(node.value).is_integer()):
            raise self._fail("exponent must be an integer constant", node)
        exponent = sign * int(node.value)
        if abs(exponent) > MAX_POWER:
            raise self._fail(f"exponent {exponent} exceeds {MAX_POWER}", node)
        return exponent


def _collect_parameters(node: Node) -> set[str]:
    names = {node.name} if node.op == "param" else set()
    for arg in node.args:
        names |= _collect_parameters(arg)
    return names


def _evaluate(node: Node, x: NDArray, params: Mapping[str, float], with_dvar: bool) -> Dual:
    op = node.op
    if op == "num":
        return Dual(np.full(x.shape, node.value, dtype=complex))
    if op == "var":
        return Dual(x.copy(), {}, np.ones(x.shape, dtype=complex) if with_dvar else None)
    if op == "param":
        value = float(params[node.name])
        return Dual(np.full(x.shape, value, dtype=complex), {node.name: np.ones(x.shape, dtype=complex)})
    args = [_evaluate(a, x, params, with_dvar) for a in node.args]
    if op == "neg":
        return args[0].mul(Dual(np.full(x.shape, -1.0, dtype=complex)))
    if op == "pow":
        return args[0].power(node.exponent)
    if op == "add":
        return args[0].add(args[1])
    if op == "sub":
        return args[0].add(args[1], -1.0)
    if op == "mul":
        return args[0].mul(args[1])
    return args[0].div(args[1])


def _to_rational(node: Node, params: Mapping[str, float]) -> Rational:
    op = node.op
    if op == "num":
        return Rational.constant(node.value)
    if op == "var":
        return Rational.variable()
    if op == "param":
        return Rational.constant(float(params[node.name]))
    args = [_to_rational(a, params) for a in node.args]
    if op == "neg":
        return -args[0]
    if op == "pow":
        return args[0] ** node.exponent
    if op == "add":
        return args[0] + args[1]
    if op == "sub":
        return args[0] - args[1]
    if op == "mul":
        return args[0] * args[1]
    return args[0] / args[1]

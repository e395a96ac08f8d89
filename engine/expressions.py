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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .errors import ExpressionError, ParameterError
from .polynomials import Rational

VARIABLES = ("s", "w", "z")
MAX_POWER = 64
MAX_LENGTH = 10_000


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
        self.root = _Parser(text, variable).parse()
        self.parameters: tuple[str, ...] = tuple(sorted(_collect_parameters(self.root)))
        self._cache: dict[tuple, object] = {}
        self._constants = _constant_subtrees(self.root)

    def _cached(self, what: str, params: Mapping[str, float], make):
        """Results for the last few parameter values (rational forms are reused a lot)."""
        self._check_params(params)
        key = (what,) + tuple(float(params[p]) for p in self.parameters)
        if key not in self._cache:
            if len(self._cache) > 32:
                self._cache.clear()
            self._cache[key] = make()
        return self._cache[key]

    def __repr__(self) -> str:
        return f"Expression({self.text!r}, variable={self.variable!r})"

    def evaluate(
        self, x: NDArray[np.complex128], params: Mapping[str, float], with_dvar: bool = False
    ) -> Dual:
        """Value at every point of ``x`` with derivatives w.r.t. every parameter."""
        self._check_params(params)
        x = np.asarray(x, dtype=complex)
        with np.errstate(divide="ignore", invalid="ignore"):
            dual = _evaluate(self.root, x, params, with_dvar)
        return _broadcast(dual, x.shape, with_dvar)

    def compile(self, params: Mapping[str, float]) -> Evaluator:
        """A fast evaluator of (value, d/dvariable) for fixed parameter values.

        Subtrees of low degree are folded into small polynomial ratios
        (evaluated by Horner's rule); larger products stay products, so the
        accuracy of a factored form is kept.
        """
        return _as_callable(self._cached("compiled", params, lambda: _compile(self.root, params, self._constants)))

    def folded(self, params: Mapping[str, float]) -> Rational | None:
        """The expression as a polynomial ratio of degree <= FOLD_DEGREE, else None."""
        compiled = self._cached("compiled", params, lambda: _compile(self.root, params, self._constants))
        return compiled.rational() if isinstance(compiled, _Folded) else None

    def rational(self, params: Mapping[str, float]) -> Rational:
        """The expression as a ratio of polynomials in the variable."""
        return self._cached("rational", params, lambda: _to_rational(self.root, params))

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
        if len(self.text) > MAX_LENGTH:
            raise ExpressionError(f"expression longer than {MAX_LENGTH} characters", self.text[:40] + "...")
        # '^' means power; Python would read it as xor with a lower precedence than '+'
        self.carets = [i for i, ch in enumerate(self.text) if ch == "^"]
        source = self.text.replace("^", "**")
        try:
            tree = ast.parse(source, mode="eval")
        except SyntaxError as exc:
            col = self._original_column(source, (exc.offset or 1) - 1)
            token = self.text[col:col + 1] if col < len(self.text) else "end of input"
            reason = exc.msg.removeprefix("invalid syntax").strip(" .") or "invalid syntax"
            if "forgot a comma" in reason:
                reason = "a missing operator (write '*' for products)"
            raise ExpressionError(f"{reason} near {token!r}", self.text, col) from None
        except (ValueError, RecursionError, MemoryError):
            raise ExpressionError("expression cannot be read", self.text) from None
        return self._node(tree.body)

    def _original_column(self, source: str, col: int) -> int:
        """Map a column of the '^'-rewritten source back to the user's text."""
        before = sum(1 for i in self.carets if i + self.carets.index(i) < col)
        return max(0, min(col - before, len(self.text)))

    def _fail(self, message: str, node: ast.AST) -> ExpressionError:
        col = getattr(node, "col_offset", None)
        col = None if col is None else self._original_column(self.text.replace("^", "**"), col)
        return ExpressionError(message, self.text, col)

    def _node(self, node: ast.AST) -> Node:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise self._fail(f"unsupported constant {node.value!r}", node)
            try:
                value = float(node.value)
            except OverflowError:
                value = float("inf")
            if not np.isfinite(value):
                raise self._fail("non-finite number", node)
            return Node("num", value=value)
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
            source = self.text.replace("^", "**")
            col = source.find("(", getattr(node.func, "end_col_offset", node.col_offset))
            col = self._original_column(source, col if col >= 0 else node.col_offset)
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


def _broadcast(dual: Dual, shape: tuple[int, ...], with_dvar: bool) -> Dual:
    """Constants and parameters evaluate to scalars; give every part the full shape."""

    def full(v) -> NDArray:
        return v if np.shape(v) == shape else np.full(shape, v, dtype=complex)

    dvar = full(0.0 if dual.dvar is None else dual.dvar) if with_dvar else None
    return Dual(full(dual.value), {k: full(g) for k, g in dual.grad.items()}, dvar)


def _evaluate(node: Node, x: NDArray, params: Mapping[str, float], with_dvar: bool) -> Dual:
    """Forward-mode evaluation; subtrees free of the variable stay scalars."""
    op = node.op
    if op == "num":
        return Dual(np.complex128(node.value))
    if op == "var":
        return Dual(x, {}, 1.0 if with_dvar else None)
    if op == "param":
        return Dual(np.complex128(float(params[node.name])), {node.name: 1.0})
    args = [_evaluate(a, x, params, with_dvar) for a in node.args]
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


def _to_rational(node: Node, params: Mapping[str, float]) -> Rational:
    op = node.op
    if op == "num":
        return Rational.constant(node.value)
    if op == "var":
        return Rational.variable()
    if op == "param":
        return Rational.constant(float(params[node.name]))
    return _combine_rationals(op, [_to_rational(a, params) for a in node.args], node.exponent)


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


class _Folded:
    """A small polynomial ratio met while compiling; becomes a Rational at the end."""

    __slots__ = ("num", "den")

    def __init__(self, num: Poly, den: Poly):
        self.num, self.den = num, den

    @property
    def degree(self) -> int:
        return max(len(self.num), len(self.den)) - 1

    def combine(self, op: str, other: "_Folded | None", exponent: int) -> "_Folded":
        if op == "neg":
            return _Folded(tuple(-c for c in self.num), self.den)
        if op == "pow":
            base = self if exponent >= 0 else _Folded(self.den, self.num)
            out = _Folded((1.0,), (1.0,))
            for _ in range(abs(exponent)):
                out = _Folded(_pmul(out.num, base.num), _pmul(out.den, base.den))
            return out
        if op in ("add", "sub"):
            num = other.num if op == "add" else tuple(-c for c in other.num)
            if self.den == other.den:
                return _Folded(_padd(self.num, num), self.den)
            return _Folded(_padd(_pmul(self.num, other.den), _pmul(num, self.den)), _pmul(self.den, other.den))
        if op == "mul":
            return _Folded(_pmul(self.num, other.num), _pmul(self.den, other.den))
        return _Folded(_pmul(self.num, other.den), _pmul(self.den, other.num))

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


def _as_callable(c: "_Folded | Evaluator") -> Evaluator:
    return _rational_evaluator(c.rational()) if isinstance(c, _Folded) else c


def _constant_subtrees(root: Node) -> dict[int, "_Folded | Evaluator"]:
    """The compiled form of every largest subtree without parameters (by node
    id): compiled once, reused whenever the parameters change."""
    constants: dict[int, _Folded | Evaluator] = {}

    def visit(node: Node) -> bool:  # True when the subtree has no parameter
        free = [visit(a) for a in node.args]
        if node.op != "param" and all(free):
            return True
        for arg, is_free in zip(node.args, free):
            if is_free and arg.op not in ("num", "var"):
                constants[id(arg)] = _compile(arg, {}, {})
        return False

    if visit(root) and root.op not in ("num", "var"):
        constants[id(root)] = _compile(root, {}, {})
    return constants


def _compile(node: Node, params: Mapping[str, float],
             constants: dict[int, "_Folded | Evaluator"]) -> "_Folded | Evaluator":
    """Fold subtrees of degree <= FOLD_DEGREE into polynomial ratios; keep the
    rest as closures (``constants``: parameter-free subtrees already compiled)."""
    if id(node) in constants:
        return constants[id(node)]
    op = node.op
    if op == "num":
        return _Folded((node.value,), (1.0,))
    if op == "var":
        return _Folded((1.0, 0.0), (1.0,))
    if op == "param":
        return _Folded((float(params[node.name]),), (1.0,))
    args = [_compile(a, params, constants) for a in node.args]
    if all(isinstance(a, _Folded) for a in args):
        folded = args[0].combine(op, args[1] if len(args) > 1 else None, node.exponent)
        if folded.degree <= FOLD_DEGREE:
            return folded
    f = [_as_callable(a) for a in args]
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

"""The numerical kernel is written once (issue 48): each piece of pole-zero arithmetic has one
module, and these patterns, read from the syntax trees of engine/, sessions/ and tui/, stand
nowhere else.

- a product of root factors, prod(x - root) (np.prod over a difference, or any
  np.multiply.reduce): `engine/model/paired_product.py`;
- a log-derivative sum, sum 1/(x - root): the same module;
- an Aberth correction, 1/(f'/f - sum 1/(x_i - x_j)): `engine/numerics/aberth.py`;
- s = ln(z)/T, a logarithm divided by a sample time: `engine/model/bilinear.py`;
- factor text from roots, a quadratic written '^2' from a root: `engine/model/factor_text.py`.

Other products of differences are other jobs, listed with why in `OTHER_JOBS`."""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("engine", "sessions", "tui")

KERNEL = "engine/model/paired_product.py"
ABERTH = "engine/numerics/aberth.py"
BILINEAR = "engine/model/bilinear.py"
FACTOR_TEXT = "engine/model/factor_text.py"

# (module, function; "*": the whole module): the same syntax doing another job
OTHER_JOBS = {
    # residues b_j = k N(p_j) (D + k N)(-p_j) / prod(p_i^2 - p_j^2) of a fraction sum's poles: products
    # of differences between root sets, the weights of a pencil (no evaluation of the loop)
    ("engine/margins/pole_zero/levels.py", "distance_stationary"),
    # the bundled examples write their plants from modal data (s^2 + 2 zeta w s + w^2), not from roots
    ("sessions/examples/coebra_launch_vehicle.py", "*"),
    ("sessions/examples/coebra_launch_vehicle_matrix.py", "*"),
}


def _modules() -> list[Path]:
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))


def _calls(node: ast.AST, names: tuple[str, ...]) -> bool:
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
    if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Attribute) and f.value.attr == "multiply":
        name = "multiply.reduce" if f.attr == "reduce" else name
    return name in names


def _has_difference(node: ast.AST) -> bool:
    return any(
        (isinstance(n, ast.BinOp) and isinstance(n.op, ast.Sub))
        or (isinstance(n, ast.UnaryOp) and isinstance(n.op, ast.USub))
        for n in ast.walk(node)
    )


def _is_one(node: ast.AST) -> bool:
    return isinstance(node, ast.Constant) and node.value in (1, 1.0)


def _reciprocal_of_difference(node: ast.AST) -> bool:
    """1 / (a - b), the term of a log-derivative sum."""
    return (
        isinstance(node, ast.BinOp)
        and isinstance(node.op, ast.Div)
        and _is_one(node.left)
        and isinstance(node.right, ast.BinOp)
        and isinstance(node.right.op, ast.Sub)
    )


def _sample_time(node: ast.AST) -> bool:
    text = ast.unparse(node)
    return "sample_time" in text or text in ("T", "self.T")


class Finder(ast.NodeVisitor):
    """Every forbidden pattern in a module, with the function it stands in."""

    def __init__(self) -> None:
        self.found: list[tuple[str, str, int]] = []  # (pattern, function, line)
        self.function = ""

    def visit_FunctionDef(self, node: ast.FunctionDef) -> None:
        outer, self.function = self.function, self.function or node.name
        self.generic_visit(node)
        self.function = outer

    visit_AsyncFunctionDef = visit_FunctionDef  # type: ignore[assignment]

    def visit_Call(self, node: ast.Call) -> None:
        product = _calls(node, ("prod",)) and node.args and _has_difference(node.args[0])
        if product or _calls(node, ("multiply.reduce",)):
            self.found.append(("product of root factors", self.function, node.lineno))
        if _calls(node, ("sum",)) and node.args and any(_reciprocal_of_difference(n) for n in ast.walk(node.args[0])):
            self.found.append(("log-derivative sum", self.function, node.lineno))
        self.generic_visit(node)

    def visit_BinOp(self, node: ast.BinOp) -> None:
        if isinstance(node.op, ast.Div):
            if _calls(node.left, ("log",)) and _sample_time(node.right):
                self.found.append(("ln(z)/T", self.function, node.lineno))
            right = node.right
            if _is_one(node.left) and isinstance(right, ast.BinOp) and isinstance(right.op, ast.Sub):
                if _calls(right.right, ("sum",)):
                    self.found.append(("Aberth correction", self.function, node.lineno))
            if isinstance(right, ast.BinOp) and isinstance(right.op, ast.Sub) and _is_one(right.left):
                if isinstance(right.right, ast.BinOp) and _calls(right.right.right, ("sum",)):
                    self.found.append(("Aberth correction", self.function, node.lineno))
        self.generic_visit(node)

    def visit_JoinedStr(self, node: ast.JoinedStr) -> None:
        literal = "".join(v.value for v in node.values if isinstance(v, ast.Constant) and isinstance(v.value, str))
        if "^2" in literal:
            self.found.append(("factor text from roots", self.function, node.lineno))
        self.generic_visit(node)


ALLOWED = {
    "product of root factors": {KERNEL},
    "log-derivative sum": {KERNEL},
    "Aberth correction": {ABERTH},
    "ln(z)/T": {BILINEAR},
    "factor text from roots": {FACTOR_TEXT},
}


@functools.cache
def _found() -> list[tuple[str, str, str, int]]:
    out = []
    for path in _modules():
        finder = Finder()
        finder.visit(ast.parse(path.read_text(), filename=str(path)))
        name = path.relative_to(ROOT).as_posix()
        out += [(pattern, name, function, line) for pattern, function, line in finder.found]
    return out


def test_each_piece_of_pole_zero_arithmetic_stands_in_its_one_module():
    misplaced = [
        f"{name}:{line} ({function}): {pattern}"
        for pattern, name, function, line in _found()
        if name not in ALLOWED[pattern] and (name, function) not in OTHER_JOBS and (name, "*") not in OTHER_JOBS
    ]
    assert not misplaced, "written again outside the kernel:\n" + "\n".join(misplaced)


@pytest.mark.parametrize("pattern", sorted(ALLOWED))
def test_the_finder_sees_each_pattern_where_it_lives(pattern):
    """The finder is no test that cannot fail: each pattern is found in its own module."""
    assert any(p == pattern and name in ALLOWED[p] for p, name, _, _ in _found())


@pytest.mark.parametrize(
    "source, pattern",
    [
        ("np.prod(s - zeros) / np.prod(s - poles)", "product of root factors"),
        ("np.multiply.reduce(x - roots, axis=0)", "product of root factors"),
        ("np.sum(1.0 / (s[:, None] - p[None, :]), axis=1)", "log-derivative sum"),
        ("np.log(z) / sample_time", "ln(z)/T"),
        ("cmath.log(r) / T", "ln(z)/T"),
        ("1.0 / (slope - np.sum(1.0 / gaps, axis=1))", "Aberth correction"),
        ("newton / (1.0 - newton * np.sum(others, axis=1))", "Aberth correction"),
        ("f'(s^2 + {b} s + {c})'", "factor text from roots"),
    ],
)
def test_the_finder_flags_a_copy(source, pattern):
    finder = Finder()
    finder.visit(ast.parse(source))
    assert pattern in {p for p, _, _ in finder.found}

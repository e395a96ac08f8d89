"""Small helpers written once (issue 48, section 3): each pattern below is allowed in
the one module that serves it (where it may be written otherwise), and found nowhere
else in engine/, sessions/ or tui/."""

from __future__ import annotations

import ast
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.test_layout import ROOT, product_modules


def _is_call(node: ast.AST, name: str) -> bool:
    """A call of ``name`` or of ``something.name``."""
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    return (isinstance(f, ast.Name) and f.id == name) or (isinstance(f, ast.Attribute) and f.attr == name)


def truncated_by_hand(node: ast.AST) -> bool:
    """``text[:n] + "..."``: a shortened text (engine.errors.shortened)."""
    return (
        isinstance(node, ast.BinOp)
        and isinstance(node.op, ast.Add)
        and isinstance(node.left, ast.Subscript)
        and isinstance(node.left.slice, ast.Slice)
        and isinstance(node.right, ast.Constant)
        and node.right.value in ("...", "…")
    )


def finite_or_none_by_hand(node: ast.AST) -> bool:
    """``x if isfinite(x) else None`` or ``float(x) if ...`` (engine.stepping.memory_fields.finite_or_none)."""
    if not (
        isinstance(node, ast.IfExp)
        and isinstance(node.orelse, ast.Constant)
        and node.orelse.value is None
        and _is_call(node.test, "isfinite")
    ):
        return False
    tested, body = ast.dump(node.test.args[0]), node.body
    return ast.dump(body) == tested or (_is_call(body, "float") and ast.dump(body.args[0]) == tested)


def pydantic_error_read(node: ast.AST) -> bool:
    """``exc.errors()[0]``: a pydantic error read (sessions.format.checks.invalid)."""
    return isinstance(node, ast.Subscript) and _is_call(node.value, "errors")


def json_tree_walk(node: ast.AST) -> bool:
    """``isinstance(a, dict) and isinstance(b, dict)``: two JSON trees walked side by side
    (sessions.format.json_diff.changes)."""
    if not (isinstance(node, ast.BoolOp) and isinstance(node.op, ast.And)):
        return False
    subjects = {
        ast.dump(v.args[0])
        for v in node.values
        if _is_call(v, "isinstance") and isinstance(v.args[1], ast.Name) and v.args[1].id == "dict"
    }
    return len(subjects) >= 2


def lru_by_hand(node: ast.AST) -> bool:
    """An ``OrderedDict()`` made: a cache kept by hand (engine.derived.Derived)."""
    return _is_call(node, "OrderedDict")


def axis_rule_by_hand(node: ast.AST) -> bool:
    """The imaginary axis's tolerances (``AXIS``, ``ORIGIN``) imported from the realization: the
    rule of a pole on the axis written again (engine.loop.realization.on_the_axis, unstable_rows)."""
    return (
        isinstance(node, ast.ImportFrom)
        and node.module == "engine.loop.realization"
        and any(alias.name in ("AXIS", "ORIGIN") for alias in node.names)
    )


PATTERNS: dict[str, tuple[Callable[[ast.AST], bool], str]] = {
    "the imaginary axis's rule by hand": (axis_rule_by_hand, "engine/loop/realization.py"),
    "truncated by hand": (truncated_by_hand, "engine/errors.py"),
    "finite-or-None by hand": (finite_or_none_by_hand, "engine/stepping/memory_fields.py"),
    "pydantic error read": (pydantic_error_read, "sessions/format/checks.py"),
    "JSON trees walked": (json_tree_walk, "sessions/format/json_diff.py"),
    "a cache kept by hand": (lru_by_hand, "engine/derived.py"),
}


def found(pattern: Callable[[ast.AST], bool]) -> set[str]:
    paths: list[Path] = list(product_modules().values())
    return {
        str(path.relative_to(ROOT))
        for path in paths
        if any(pattern(node) for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))))
    }


@pytest.mark.parametrize("name", sorted(PATTERNS))
def test_each_small_helper_is_written_in_one_module(name):
    pattern, home = PATTERNS[name]
    assert found(pattern) <= {home}


def test_the_patterns_find_what_they_name():
    samples = {
        "truncated by hand": "t = text[:37] + '...'",
        "finite-or-None by hand": "y = x if math.isfinite(x) else None",
        "pydantic error read": "first = exc.errors()[0]",
        "JSON trees walked": "same = isinstance(a, dict) and isinstance(b, dict)",
        "a cache kept by hand": "kept = OrderedDict()",
        "the imaginary axis's rule by hand": "from engine.loop.realization import AXIS, StateSpace",
    }
    for name, (pattern, _) in PATTERNS.items():
        assert any(pattern(node) for node in ast.walk(ast.parse(samples[name]))), name
        assert not any(pattern(node) for node in ast.walk(ast.parse("x = a + b"))), name

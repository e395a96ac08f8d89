"""The direction of imports: engine knows nothing of sessions or tui; sessions nothing of tui."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def imported_top_levels(package: str) -> set[tuple[str, str]]:
    found = set()
    for path in (ROOT / package).rglob("*.py"):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                found |= {(alias.name.split(".")[0], str(path)) for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add((node.module.split(".")[0], str(path)))
    return found


@pytest.mark.parametrize(
    "package, forbidden",
    [
        ("engine", {"tui", "sessions", "textual", "textual_plotext", "plotext"}),
        ("sessions", {"tui", "textual", "textual_plotext", "plotext"}),
    ],
)
def test_import_direction(package, forbidden):
    offenders = [(mod, path) for mod, path in imported_top_levels(package) if mod in forbidden]
    assert offenders == []


def test_the_check_sees_imports():
    """The scan itself must find imports, or the test above could never fail."""
    assert ("numpy", str(ROOT / "engine" / "model" / "network.py")) in imported_top_levels("engine")

"""The layout's rules (docs/architecture.md): a private name of a product
module is used only in that module; no package level holds more than about
ten modules; the architecture page names every module."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("engine", "sessions", "tui")
MOST_MODULES = 11  # "about ten" modules at one package level (not counting __init__)


def product_modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found[name] = path
    return found


def private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_uses(module: str, path: Path, modules: dict[str, Path]) -> list[str]:
    """Every private name of another product module that ``module`` imports or reads
    as an attribute of that module."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    bound: dict[str, str] = {}  # local name -> product module it names
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                full = f"{node.module}.{alias.name}"
                if full in modules:
                    bound[alias.asname or alias.name] = full
                elif node.module in modules and node.module != module and private(alias.name):
                    found.append(f"{module} imports {full}")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in modules:
                    bound[alias.asname or alias.name] = alias.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and private(node.attr):
            target = node.value
            dotted = []
            while isinstance(target, ast.Attribute):
                dotted.insert(0, target.attr)
                target = target.value
            if isinstance(target, ast.Name) and target.id in bound:
                owner = ".".join([bound[target.id], *dotted])
                if owner in modules and owner != module:
                    found.append(f"{module} reads {owner}.{node.attr}")
    return found


def test_no_private_name_is_used_outside_its_module():
    modules = product_modules()
    offenders = [use for name, path in modules.items() for use in private_uses(name, path, modules)]
    assert offenders == []


def test_the_private_check_sees_a_private_import(tmp_path):
    """The scan must find both forms, or the test above could never fail."""
    modules = {"engine.a": tmp_path / "a.py", "engine.b": tmp_path / "b.py"}
    modules["engine.b"].write_text("from engine.a import _hidden\nimport engine.a as a\nx = a._other\n")
    assert private_uses("engine.b", modules["engine.b"], modules) == [
        "engine.b imports engine.a._hidden",
        "engine.b reads engine.a._other",
    ]


def test_no_package_level_holds_more_than_about_ten_modules():
    crowded = {}
    for package in PACKAGES:
        for folder in [ROOT / package, *(p for p in (ROOT / package).rglob("*") if p.is_dir())]:
            if not (folder / "__init__.py").exists():
                continue
            count = len([p for p in folder.glob("*.py") if p.name != "__init__.py"])
            if count > MOST_MODULES:
                crowded[str(folder.relative_to(ROOT))] = count
    assert crowded == {}


def test_the_architecture_page_names_every_module():
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    named = set(re.findall(r"`((?:engine|sessions|tui)/[\w/]+\.py)`", page))
    files = {str(path.relative_to(ROOT)) for path in product_modules().values() if path.name != "__init__.py"}
    assert sorted(files - named) == [], "modules the page does not name"
    assert sorted(named - files) == [], "modules the page names that do not exist"


def test_workers_answer_by_posted_messages_and_the_app_is_composed_not_mixed():
    """One way back from a thread worker (a posted message, handled with @on), and the
    app's and the main screen's state in composed parts, not mixins sharing self."""
    from textual.app import App
    from textual.screen import Screen

    from tui.app import LoopcraftApp
    from tui.screens.main import MainScreen

    calls = [str(p.relative_to(ROOT)) for p in (ROOT / "tui").rglob("*.py") if "call_from_thread" in p.read_text()]
    assert calls == []
    assert LoopcraftApp.__bases__ == (App,) and MainScreen.__bases__ == (Screen,)

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


APP_PARTS = {"bench", "edit_flow", "busy", "runs", "sweeps", "exports"}
APP_MODULES = ("tui.app", "tui.screens", "tui.actions", "tui.state.workbench")


def seam_faults(path: Path) -> list[str]:
    """What a widget or drawing module does across the seam: reaches the app's parts
    (``self.app.bench``, ``self.app.edit_flow``, ``self.app.busy``, ...) or imports the
    app, its screens, its workers or the `Workbench`."""
    faults = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Attribute) and node.attr in APP_PARTS:
            if isinstance(node.value, ast.Attribute) and node.value.attr == "app":
                faults.append(f"{path.name}:{node.lineno}: app.{node.attr}")
        modules = (
            [alias.name for alias in node.names]
            if isinstance(node, ast.Import)
            else [node.module or ""]
            if isinstance(node, ast.ImportFrom)
            else []
        )
        faults += [f"{path.name}:{node.lineno}: imports {m}" for m in modules if m.startswith(APP_MODULES)]
    return faults


def test_widgets_and_drawing_never_touch_the_workbench_or_the_apps_parts():
    """Issue 54: a widget posts messages and the screen's controllers apply them; drawing
    draws figures.  Neither reads or writes the `Workbench` or the app's parts."""
    paths = [*(ROOT / "tui" / "widgets").rglob("*.py"), *(ROOT / "tui" / "drawing").rglob("*.py")]
    assert [fault for path in paths for fault in seam_faults(path)] == []


def test_the_seam_check_sees_a_reach_into_the_app(tmp_path):
    widget = tmp_path / "widget.py"
    widget.write_text("from tui.state.workbench import Workbench\n\ndef f(self):\n    return self.app.bench\n")
    assert seam_faults(widget) == ["widget.py:1: imports tui.state.workbench", "widget.py:4: app.bench"]


def test_the_key_table_imports_no_widget():
    """`tui.keys` is imported by every widget: it imports nothing of the app (no circle)."""
    modules = {mod for mod, path in imported_top_levels("tui") if path.endswith("tui/keys.py")}
    tree = ast.parse((ROOT / "tui" / "keys.py").read_text())
    inner = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("tui")]
    assert "tui" not in modules and inner == []

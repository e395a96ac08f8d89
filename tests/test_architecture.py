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
APP_MODULES = ("tui.app", "tui.screens", "tui.actions", "tui.state.workbench", "tui.state.bench")


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


def imports_of(path: Path) -> list[tuple[int, str]]:
    """The modules a module imports (line, module), at its top, in a function or for a type hint
    (under ``if TYPE_CHECKING:``)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
    return found


def engine_imports(path: Path) -> list[str]:
    """Where a module imports the engine or the sessions package (anywhere: a type hint's too),
    but for the one store of derived forms (`STORE`)."""
    return [
        f"{path.name}:{line}: imports {m}"
        for line, m in imports_of(path)
        if m.split(".")[0] in ENGINE_SIDE and m != STORE
    ]


ENGINE_SIDE = {"engine", "sessions"}
# the one bounded, thread-safe cache of the code (tests/test_shared_helpers.py: no other is kept by
# hand): a store, not a computation; the drawing keeps its static layers in one
STORE = "engine.derived"


def test_widgets_and_drawing_never_call_the_engine():
    """Issue 54: `tui/figures` may call the engine (in workers); `tui/drawing` and the widgets
    never do: they import nothing of `engine` or `sessions`, not even for a type hint, but the
    one store of derived forms (`engine.derived`: the drawing's static layers are kept in one; the
    code's one cache, tests/test_shared_helpers.py); the matrix grid is chosen in `tui.state`; the
    shaping table reads its items through a protocol of its own."""
    paths = [*(ROOT / "tui" / "widgets").rglob("*.py"), *(ROOT / "tui" / "drawing").rglob("*.py")]
    assert [fault for path in paths for fault in engine_imports(path)] == []


def test_the_engine_check_sees_an_import(tmp_path):
    drawing = tmp_path / "drawing.py"
    drawing.write_text(
        "from typing import TYPE_CHECKING\n"
        "from engine.derived import Derived\n"
        "from engine.derived_forms import x\n"
        "import sessions.store, numpy\n"
        "if TYPE_CHECKING:\n"
        "    from engine.design.compensator_items import Item\n"
        "def f():\n"
        "    from engine.margins import margins\n"
        "    return margins\n"
    )
    assert engine_imports(drawing) == [
        "drawing.py:3: imports engine.derived_forms",
        "drawing.py:4: imports sessions.store",
        "drawing.py:6: imports engine.design.compensator_items",
        "drawing.py:8: imports engine.margins",
    ]


def test_the_key_table_imports_no_widget():
    """`tui.keys` is imported by every widget: it imports nothing of the app (no circle)."""
    modules = {mod for mod, path in imported_top_levels("tui") if path.endswith("tui/keys.py")}
    tree = ast.parse((ROOT / "tui" / "keys.py").read_text())
    inner = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("tui")]
    assert "tui" not in modules and inner == []


SESSION_WRITER = ROOT / "tui" / "state" / "bench" / "records.py"
MUTATORS = {"append", "extend", "insert", "pop", "remove", "clear", "update", "sort", "reverse", "setdefault"}


def _reaches_session(node: ast.AST, aliases: set[str]) -> bool:
    """Whether an attribute chain (``bench.session.model.problem``, ``model.records[0]``) goes
    through a ``.session`` attribute or starts at a name bound to one."""
    while isinstance(node, (ast.Attribute, ast.Subscript)):
        if isinstance(node, ast.Attribute) and node.attr == "session":
            return True
        node = node.value
    return isinstance(node, ast.Name) and node.id in aliases


def _written(target: ast.AST) -> list[ast.AST]:
    """The places an assignment's target writes (a tuple's items; a bare name writes nothing)."""
    if isinstance(target, (ast.Tuple, ast.List)):
        return [t for item in target.elts for t in _written(item)]
    return [target] if isinstance(target, (ast.Attribute, ast.Subscript)) else []


def session_writes(path: Path) -> list[str]:
    """Where a module changes a session it reaches through ``.session``: an assignment, an
    augmented assignment or a ``del`` of a place on it (directly or through a name bound to
    it in the same function, ``model = bench.session.model``), or a list or dict method that
    changes it in place (``...session.model.records.clear()``)."""
    faults = []
    scopes = [n for n in ast.walk(ast.parse(path.read_text(), filename=str(path))) if isinstance(n, ast.FunctionDef)]
    for scope in scopes:
        aliases: set[str] = set()
        for node in ast.walk(scope):
            if isinstance(node, ast.Assign) and _reaches_session(node.value, aliases):
                aliases |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        for node in ast.walk(scope):
            targets = (
                node.targets
                if isinstance(node, (ast.Assign, ast.Delete))
                else [node.target]
                if isinstance(node, (ast.AugAssign, ast.AnnAssign))
                else []
            )
            places = [place for target in targets for place in _written(target)]
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in MUTATORS:
                places.append(node.func.value)
            faults += [f"{path.name}:{node.lineno}: {ast.unparse(p)}" for p in places if _reaches_session(p, aliases)]
    return sorted(set(faults))


def test_one_writer_of_the_session():
    """Issue 54: the records part alone changes the open session (`RecordBook`: an edit's
    problem through `replace_problem`, its undo step through `edit`); every other module of
    the workbench asks it."""
    paths = [p for p in (ROOT / "tui").rglob("*.py") if p != SESSION_WRITER]
    assert [fault for path in paths for fault in session_writes(path)] == []


def test_the_writer_check_sees_writes(tmp_path):
    module = tmp_path / "edits.py"
    module.write_text(
        "def f(bench, draft):\n"
        "    bench.session.model.problem, bench.session.problem = draft, 1\n"
        "    settings = bench.session.model.algorithm.settings\n"
        "    settings['x'] = 2\n"
        "    model = bench.session.model\n"
        "    model.records.clear()\n"
        "    del model.records[1:]\n"
        "    bench.session = None\n"
        "    value = bench.session.model.state\n"
        "    value = 3\n"
    )
    assert session_writes(module) == [
        "edits.py:2: bench.session.model.problem",
        "edits.py:2: bench.session.problem",
        "edits.py:4: settings['x']",
        "edits.py:6: model.records",
        "edits.py:7: model.records[1:]",
        "edits.py:8: bench.session",
    ]
    assert session_writes(SESSION_WRITER) != []  # the writer itself is seen writing

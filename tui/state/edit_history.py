"""Undo and redo of edits of the problem, apart from undoing iterations.

Before an edit the workbench's changeable content is kept as a `Snapshot`:
the problem model, the algorithm and its settings, the records and the
current iteration, the earlier runs and hand moves, and the engine problem built from that model (so an undo
needs no rebuild).  An accepted edit pushes the snapshot with a description
of what changed, read off the two models ("parameter K value: 1 -> 2");
undoing it puts the snapshot back (`RecordBook.restore`), records included: iterations an edit
dropped come back with the edit's undo.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

from engine.errors import shortened
from sessions.format.json_diff import Change, Path, changes

if TYPE_CHECKING:
    from tui.state.bench.records import RecordBook

MAX_EDITS = 100  # undo depth: the oldest edit is forgotten beyond it


@dataclass
class Snapshot:
    """What an edit can change in a workbench."""

    problem_model: Any
    algorithm: Any
    records: list
    current_iteration: int
    state: Any
    problem: Any
    parsed_records: list
    earlier: list

    @classmethod
    def of(cls, book: RecordBook) -> Snapshot:
        model = book.session.model
        return cls(
            model.problem.model_copy(deep=True),
            model.algorithm.model_copy(deep=True),
            list(model.records),
            model.current_iteration,
            model.state,
            book.session.problem,
            book.parsed_records(),
            list(model.earlier),
        )

    @cached_property
    def dumped(self) -> dict:
        """The problem model and the algorithm as JSON data (what `describe_change` compares
        against: a burst's first snapshot is compared at each of its edits)."""
        return _dump(self.problem_model, self.algorithm)


class EditHistory:
    """The undo and redo stacks of one workbench's edits."""

    def __init__(self) -> None:
        self.undo_stack: list[tuple[str, Snapshot]] = []
        self.redo_stack: list[tuple[str, Snapshot]] = []
        self.last = ""  # what the latest edit, undo or redo did (the status line shows it)
        self._burst: object = None  # the burst the latest edit belongs to (`push`); None: ended

    def continues(self, burst: object) -> bool:
        """Whether an edit of ``burst`` joins the undo step of the edits before it."""
        return burst is not None and burst == self._burst and bool(self.undo_stack)

    def push(self, before: Snapshot | None, after: RecordBook, burst: object = None) -> str | None:
        """Keep ``before`` as the undo of an edit that led to ``after``'s state;
        its description (None when nothing changed).  Edits of one ``burst`` (the same
        item nudged again by the same key, with no other action between: `end_burst`)
        are one undo step, described from the state before the first of them
        ("T1: 1 -> 1.34"; ``before`` None: an edit that `continues` one).  What joins
        them is what the user did, never a timer."""
        model = after.session.model  # read as it is: no copy of it is kept
        if self.continues(burst):
            before = self.undo_stack.pop()[1]
        assert before is not None, "an edit without its snapshot continues a burst"
        self._burst = burst
        text = describe_change(before.dumped, _dump(model.problem, model.algorithm))
        if text is None:  # back where the step began: no step, and the burst's next edit starts one
            self._burst = None
            return None
        self.undo_stack = (self.undo_stack + [(text, before)])[-MAX_EDITS:]
        self.redo_stack.clear()
        self.last = f"edit: {text}"
        return text

    def end_burst(self) -> None:
        """Another action came: the next edit starts a new undo step, whatever its burst."""
        self._burst = None

    def undo(self, book: RecordBook) -> str | None:
        """Put back the state before the latest edit; what was undone (None: nothing to undo)."""
        return self._move(book, self.undo_stack, self.redo_stack, "undid")

    def redo(self, book: RecordBook) -> str | None:
        """Apply again the latest undone edit; what was redone (None: nothing to redo)."""
        return self._move(book, self.redo_stack, self.undo_stack, "redid")

    def _move(self, book: RecordBook, source: list, target: list, verb: str) -> str | None:
        if not source:
            return None
        text, snapshot = source.pop()
        self._burst = None
        target.append((text, Snapshot.of(book)))
        book.restore(snapshot)
        self.last = f"{verb}: {text}"
        return text


def _dump(problem_model, algorithm) -> dict:
    return {"problem": problem_model.model_dump(), "algorithm": algorithm.model_dump()}


def describe_change(before: Any, after: Any, limit: int = 2) -> str | None:
    """The changed values between two JSON-like trees, as 'where: old -> new' (at most
    ``limit`` of them, then how many more); None when they are equal."""
    found = [_said(change, before) for change in changes(before, after, whole=_shown_whole, absent=None)]
    if not found:
        return None
    more = f" (+{len(found) - limit} more)" if len(found) > limit else ""
    return "; ".join(found[:limit]) + more


def _shown_whole(a: Any, b: Any) -> bool:
    """A list of plain values is compared (and shown) whole."""
    return isinstance(a, list) and _leafy(a)


def _said(change: Change, before: Any) -> str:
    """A change in the reader's words: a list's items added or removed, else 'where: old -> new'."""
    a, b, path = change.old, change.new, _names(before, change.path)
    if isinstance(a, list) and isinstance(b, list) and not (_leafy(a) and _leafy(b)):
        before, after = [_item_name(x, k) for k, x in enumerate(a)], [_item_name(x, k) for k, x in enumerate(b)]
        added = [n for n in after if n not in before] or ([after[-1]] if len(b) > len(a) else [])
        removed = [n for n in before if n not in after] or ([before[-1]] if len(a) > len(b) else [])
        parts = [f"added {', '.join(added)}"] * bool(added) + [f"removed {', '.join(removed)}"] * bool(removed)
        return f"{path[-1] if path else 'items'}: {'; '.join(parts) or 'reordered'}"
    return f"{_where(path)}: {_short(a)} -> {_short(b)}"


def _names(tree: Any, path: Path) -> list[str]:
    """The path's steps as the reader names them: keys, and list items by their name (or number)."""
    names = []
    for step in path:
        if isinstance(step, int):
            tree = tree[step]
            names.append(_item_name(tree, step))
        else:
            tree = tree.get(step) if isinstance(tree, dict) else None
            names.append(str(step))
    return names


def _leafy(items: list) -> bool:
    """A list of plain values (a per-condition value, coefficients) is shown whole."""
    return all(not isinstance(x, (dict, list)) for x in items)


def _item_name(item: Any, k: int) -> str:
    if isinstance(item, dict):
        for key in ("name", "measure"):
            if isinstance(item.get(key), str):
                return item[key]
    return f"#{k + 1}"


def _where(path: list[str]) -> str:
    skip = {"problem", "parameters", "targets", "conditions", "plant", "blocks", "transfer", "algorithm"}
    shown = [p for p in path if p not in skip] or path[-1:]
    return " ".join(shown)


def _short(value: Any) -> str:
    """A value as a reader writes it (never a Python repr): numbers in short form, lists
    joined by '/' (one per condition, coefficients, lines of text), objects by their count."""
    if value is None:
        return "none"
    if isinstance(value, float):
        text = f"{value:g}"
    elif isinstance(value, list):
        text = "/".join(_short(v) for v in value) if _leafy(value) else f"{len(value)} items"
        text = text or "none"
    elif isinstance(value, dict):
        text = f"{len(value)} fields"
    else:
        text = str(value)
    return shortened(text)

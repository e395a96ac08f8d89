"""Where two JSON trees differ, walked once for every caller: the comparison of two
sessions' problems (`sessions.compare`), the edit history's 'where: old -> new'
(`tui.state.edit_history`) and a replay's first difference (`sessions.runner`).  Each
caller says what counts as the same leaf and writes the changes in its own words;
JSON paths are written as `location` writes them."""

from __future__ import annotations

import operator
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

Path = tuple[str | int, ...]


class Absent:
    """What a key that one side of a comparison lacks reads as (`ABSENT`, unless the
    caller reads a missing key as None)."""

    def __repr__(self) -> str:
        return "ABSENT"


ABSENT = Absent()


@dataclass(frozen=True)
class Change:
    """One place where the trees differ: its path (keys and list indices), the old value
    and the new one (either `ABSENT` where its side lacks the key)."""

    path: Path
    old: Any
    new: Any


def changes(
    old: Any,
    new: Any,
    same: Callable[[Any, Any], bool] = operator.eq,
    whole: Callable[[Any, Any], bool] | None = None,
    absent: Any = ABSENT,
    path: Path = (),
) -> Iterator[Change]:
    """Every change from ``old`` to ``new``, lazily, in order: objects key by key (old's
    keys, then the new ones; a missing key read as ``absent``), lists of one length item by
    item, and anything else, or a pair ``whole`` says to compare whole, by ``same``."""
    if whole is None or not whole(old, new):
        if isinstance(old, dict) and isinstance(new, dict):
            for key in dict.fromkeys([*old, *new]):
                yield from changes(old.get(key, absent), new.get(key, absent), same, whole, absent, path + (key,))
            return
        if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
            for k, (a, b) in enumerate(zip(old, new)):
                yield from changes(a, b, same, whole, absent, path + (k,))
            return
    if not same(old, new):
        yield Change(path, old, new)


def location(path: tuple) -> str:
    """A JSON path as text: ``problem.conditions[0].plant`` ('(top)' for the whole tree)."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top)"

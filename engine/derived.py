"""Forms derived from an object that never changes, kept on it: one typed store
(`Derived`) and one invalidation rule, for an expression's compiled, rational and
pole-zero forms, a network's schedules, designs and w-plane form, a design's loops, the
levels of a loop's pole-zero form and the rational fits of tabulated loops.

The object a store belongs to never changes, so a kept form is never stale: it is a
function of its key (the kind of form, `Form`, and what it was asked with: a break
signal, the parameter values).  The one rule is a bound: a store keeps its `most`
forms used last and drops the least recently used first (a run moves through parameter
values, and the forms of the values it left are not asked again).  Thread-safe: the
workbench's workers and its UI thread ask the same stores; two threads that make one
form at once both return the first made, so a kept form is one object.  A store
pickled or copied arrives empty (its lock cannot travel; its forms are made again).

An attribute of one immutable object, made on first use and asked with nothing, is a
`functools.cached_property` of it (a `Design`'s realization, a loop's levels): it has
no key and nothing to drop."""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Generic, TypeVar, cast

T = TypeVar("T")

MOST = 32  # forms a store keeps unless its owner says otherwise


@dataclass(frozen=True, eq=False)
class Form(Generic[T]):
    """A kind of derived form, typed by what it makes; a key by its identity (its name
    says what it is)."""

    name: str


class Derived:
    """The forms kept on one object (see the module docstring)."""

    def __init__(self, most: int = MOST):
        self.most = most
        self._kept: OrderedDict[tuple, object] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, form: Form[T], make: Callable[[], T], *key: Hashable) -> T:
        """The ``form`` asked with ``key``: kept, else made by ``make()`` and kept."""
        full = (form, *key)
        with self._lock:
            if full in self._kept:
                self._kept.move_to_end(full)
                return cast(T, self._kept[full])
        made = make()
        with self._lock:
            found = self._kept.setdefault(full, made)
            self._kept.move_to_end(full)
            while len(self._kept) > self.most:
                self._kept.popitem(last=False)
        return cast(T, found)

    def __getstate__(self) -> dict:
        """A copy (pickled for a sweep's worker, deep-copied) starts empty: its forms are made again."""
        return {"most": self.most}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["most"])  # type: ignore[misc]

"""Older session files brought up to the current schema version, one version at a
time (`sessions.store` applies them as it loads, and says so in the session's
messages; the file itself is rewritten only when the user saves).

Version 2 gave each idea one name: a target that is only part of the objective
is ``requirement: false`` (was ``constraint``, a word kept for the linear
inequalities between parameters); a tableau row's desired value is ``desired``
(was ``target``); cip's margin requirements in its stored memory are
``requirements`` (was ``constraints``); a sweep run's and optimum's ranking
value is ``ranking`` (was ``objective``, the record's cost being another thing),
and a worst case's desired value ``desired`` (sweep section version 2).

A migration never raises on malformed input: what is not of the expected shape
is left as it is, for the schema's validation to name.
"""

from __future__ import annotations

from collections.abc import Callable


def _renamed(item: object, old: str, new: str) -> None:
    if isinstance(item, dict) and old in item and new not in item:
        item[new] = item.pop(old)


def _each(container: object, key: str) -> list:
    value = container.get(key) if isinstance(container, dict) else None
    return value if isinstance(value, list) else []


def _one_name_per_idea(data: dict) -> dict:
    """Version 1 -> 2 (the module's docstring)."""
    for target in _each(data.get("problem"), "targets"):
        _renamed(target, "constraint", "requirement")
    for record in _each(data, "records"):
        for row in _each(record, "measures"):
            _renamed(row, "target", "desired")
    state = data.get("state")
    if isinstance(state, dict):  # only cip's memory held "constraints" in version 1
        _renamed(state.get("memory"), "constraints", "requirements")
    for sweep in _each(data, "sweeps"):
        for run in _each(sweep, "runs"):
            _renamed(run, "objective", "ranking")
            for row in _each(run, "measures"):
                _renamed(row, "target", "desired")
        for optimum in _each(sweep, "optima"):
            _renamed(optimum, "objective", "ranking")
        for row in _each(sweep, "worst_case"):
            _renamed(row, "target", "desired")
        if isinstance(sweep, dict) and sweep.get("version") == 1:
            sweep["version"] = 2
    return data


# version -> function turning a session dict of that version into the next version's
MIGRATIONS: dict[int, Callable[[dict], dict]] = {1: _one_name_per_idea}

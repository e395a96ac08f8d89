"""A seeded, structure-aware mutator of session documents and their CSV tables.

A mutation picks a JSON path (a random walk from the root, so deep and
shallow places are both reached) and does one thing there: delete it, give
it a value of the wrong type, an extreme number, an empty or huge list, a
nasty expression, a value taken from elsewhere in the same document, or an
edit of a record or of the stored state.  `garble_csv` does the same to a
table's text.  Everything is drawn from a `random.Random`, so a case is
reproduced from its seed.
"""

from __future__ import annotations

import copy
import json
import random
from typing import Any

from engine.design.measure_kinds import MEASURE_KINDS

Path = tuple[Any, ...]

# Tokens JSON cannot carry as Python floats: written into the text as they are.
RAW = (
    "NaN",
    "Infinity",
    "-Infinity",
    "1e999",
    "-1e999",
    "-0.0",
    "1" + "0" * 400,
    "-" + "9" * 330,
    "1" * 5000,
    "1e-999",
    "0.000000000000000000000000000000000000000000000001",
)
NUMBERS: tuple[Any, ...] = (
    0,
    0.0,
    1,
    -1,
    2,
    0.5,
    -0.5,
    1e-300,
    -1e-300,
    5e-324,
    1e300,
    -1e300,
    1e308,
    -1e308,
    1.7976931348623157e308,
    1e15,
    1e-15,
    2**63,
    -(2**63),
    10**20,
    3,
    1000,
    123456789,
)
WRONG_TYPES: tuple[Any, ...] = (
    None,
    True,
    False,
    "",
    "text",
    "nan",
    "inf",
    "1e999",
    "-0",
    [],
    {},
    [1],
    [[1]],
    {"a": 1},
    0,
    "0",
    [None],
    ["s"],
    {"kind": "expression"},
)
EXPRESSIONS: tuple[str, ...] = (
    "s/s",
    "-1e308/s",
    "1e308",
    "1e308*s",
    "1e308*s**2 + 1e308",
    "1/(s-s)",
    "0",
    "0/s",
    "s*0",
    "0*s/(s+1)",
    "-" * 900 + "s",
    "s" + "+s" * 500,
    "s" + "-s*s/s" * 150,
    "(" * 300 + "s" + ")" * 300,
    "(" * 60 + "s" + ")" * 60,
    "s**1" + "0" * 400,
    "s**64",
    "(s+1)**64",
    "(s+1)**64/(s+2)**64",
    "s**-64",
    "(1e10*s+1)**40",
    "s**0.5",
    "s^s",
    "s**s",
    "sin(s)",
    "__import__('os')",
    "1e-320",
    "1e-320*s",
    "x[0]",
    "lambda: 0",
    "s if s else s",
    "(s+1)/(s+1)",
    "2*vehicle_1_x0",
    "K",
    "unknown_parameter",
    "K/(s+K)",
    "1/K",
    "s**2/(0*s+0)",
    "",
    " ",
    "s s",
    "1/(s**2+1)",
    "1/s**3",
    "1/(s+1e-300)",
    "1/(s-1)",
    "s/(s-1)**3",
    "(s**2+2*s+1)**32",
    "1/(s*(s+1)*(s+2))",
    "exp(-s)",
    "s**2",
    "s**3/(s+1)",
    "9" * 400,
    "0.0/0.0",
    "1e-300/1e300",
    "s\x00",
    "s\u2212 1",
    "1/(1e-300*s)",
    "1" + "*s" * 300,
    "(s+1)" * 200,
    "1/((s+1)" * 40 + ")" * 40,
    "w",
    "z",
    "s+w",
    "True",
    "None",
    "'s'",
    "s,s",
    "1e999",
    "NaN",
    "inf",
    "-s/(s*s+1e-30)",
    "((((s))))",
    "s**+2",
    "s**(-1)",
    "2**1000",
)
# the schema's names and enumerations: a valid-looking value of the wrong kind (a measure qcg does not know...)
ENUMS = tuple(MEASURE_KINDS) + (
    "expression",
    "polynomial",
    "factored",
    "table",
    "delay",
    "controller",
    "diagram",
    "matrix",
    "channels",
    "cascade",
    "ascending",
    "descending",
    "log",
    "linear",
    "hz",
    "rad/s",
    "polar",
    "cartesian",
    "magnitude",
    "push",
    "pull",
    "at_least",
    "at_most",
    "time_constant",
    "root",
    "second_order",
    "zero",
    "pole",
    "complex_zero",
    "complex_pole",
    "s",
    "w",
    "z",
    "cip",
    "qcg",
    "slp",
    "projection",
    "running",
    "converged",
    "failed",
    "dae",
    "quadratic_cost",
    "match",
    "e",
    "r",
    "u",
    "y",
)
SIZES = (0, 1, 2, 3, 7, 50, 101, 1001, 2001, 10_001, 100_000)


def paths(node: Any, prefix: Path = ()) -> list[Path]:
    """Every path below ``node`` (the root itself excluded)."""
    out: list[Path] = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in items:
        out.append(prefix + (key,))
        out.extend(paths(child, prefix + (key,)))
    return out


# per kind of node, the mutations that fit it (most keep its type, so that many
# mutants pass the schema and reach the engine) and their weights
_ANY = {"delete": 3, "wrong_type": 3, "transplant": 2}
ACTIONS = {
    "number": {**_ANY, "number": 12, "scale": 10, "expression": 4, "name": 3},
    "string": {**_ANY, "expression": 12, "name": 6, "enum": 6, "number": 2},
    "list": {**_ANY, "list": 8, "number": 4, "duplicate": 3, "element": 6},
    "dict": {**_ANY, "delete_key": 8, "duplicate": 2},
    "other": {**_ANY, "number": 4, "flip": 4},
}


def _shape(node: Any) -> str:
    if isinstance(node, bool) or node is None:
        return "other"
    if isinstance(node, (int, float)):
        return "number"
    return (
        "string"
        if isinstance(node, str)
        else "list"
        if isinstance(node, list)
        else "dict"
        if isinstance(node, dict)
        else "other"
    )


def walk(rng: random.Random, doc: Any, start: Path = ()) -> Path:
    """A random path: from ``start``, descend into a random child until a coin says stop."""
    path, node = start, get(doc, start)
    while isinstance(node, (dict, list)) and node:
        key = rng.choice(list(node)) if isinstance(node, dict) else rng.randrange(len(node))
        path, node = path + (key,), node[key]
        if not isinstance(node, (dict, list)) or rng.random() < 0.15:
            break
    return path


def get(doc: Any, path: Path) -> Any:
    """The node at ``path``."""
    for key in path:
        doc = doc[key]
    return doc


def put(doc: Any, path: Path, value: Any) -> None:
    """Replace the node at ``path`` (the root is never replaced)."""
    get(doc, path[:-1])[path[-1]] = value


def delete(doc: Any, path: Path) -> None:
    """Remove the node at ``path`` from its dict or list."""
    parent = get(doc, path[:-1])
    del parent[path[-1]]


class Mutator:
    """The mutations of one case, all drawn from ``rng``; `raw` collects the
    placeholders to replace by raw JSON tokens when the document is written."""

    def __init__(self, rng: random.Random):
        self.rng = rng
        self.raw: dict[str, str] = {}
        self.log: list[str] = []

    def token(self, text: str) -> str:
        """A placeholder string written as the raw token ``text``."""
        key = f"\x00raw{len(self.raw)}\x00"
        self.raw[key] = text
        return key

    def number(self) -> Any:
        """An extreme number (or a raw token such as NaN or 1e999)."""
        if self.rng.random() < 0.35:
            return self.token(self.rng.choice(RAW))
        return self.rng.choice(NUMBERS)

    def mutate(self, doc: dict, focus: Path = ()) -> None:
        """One mutation at a random path below ``focus``."""
        path = self.pick(doc, focus)
        if not path:
            return
        node = get(doc, path)
        actions = ACTIONS[_shape(node)]
        action = self.rng.choices(list(actions), weights=list(actions.values()))[0]
        value = getattr(self, f"_{action}")(doc, path, node)
        if action == "delete":
            delete(doc, path)
        elif value is not _KEEP:
            put(doc, path, value)
        self.log.append(f"{action} at {'/'.join(map(str, path))}")

    def pick(self, doc: dict, focus: Path = ()) -> Path:
        """A path below ``focus``: by a random walk, or uniformly among the document's
        kinds of place (paths with list indices as '*'), or uniformly among all paths."""
        way = self.rng.random()
        if way < 0.3:
            return walk(self.rng, doc, focus)
        found = [focus + p for p in paths(get(doc, focus))]
        if not found:
            return focus
        if way < 0.85:
            groups: dict[Path, list[Path]] = {}
            for p in found:
                groups.setdefault(tuple("*" if isinstance(k, int) else k for k in p), []).append(p)
            return self.rng.choice(groups[self.rng.choice(sorted(groups, key=str))])
        return self.rng.choice(found)

    def _delete(self, doc, path, node):
        return _KEEP

    def _wrong_type(self, doc, path, node):
        return copy.deepcopy(self.rng.choice(WRONG_TYPES))

    def _number(self, doc, path, node):
        if isinstance(node, list) and node and self.rng.random() < 0.5:
            node[self.rng.randrange(len(node))] = self.number()
            return _KEEP
        return self.number()

    def _scale(self, doc, path, node):
        """A number made huge, tiny, negative or zero (relative to what it was)."""
        if isinstance(node, bool) or not isinstance(node, (int, float)):
            return self.number()
        factor = self.rng.choice((0.0, -1.0, 1e-12, 1e12, 1e100, -1e100, 1.0000001, 10.0, 0.1))
        return node * factor

    def _list(self, doc, path, node):
        """An empty or a huge list (of copies of an element, when there is one)."""
        size = self.rng.choice(SIZES)
        if isinstance(node, list) and node:
            element = node[self.rng.randrange(len(node))]
        else:
            element = self.rng.choice((1.0, "s", 0, None, {}))
        if isinstance(element, (dict, list)) and size > 2001:
            size = self.rng.choice((1001, 2001))  # keep the document small enough to write quickly
        return [copy.deepcopy(element) for _ in range(size)] if isinstance(element, (dict, list)) else [element] * size

    def _name(self, doc, path, node):
        """A name met elsewhere in the document (a parameter, a signal, a condition)."""
        names = [v for v in _strings(doc) if len(v) < 40]
        return self.rng.choice(names) if names else "s"

    def _enum(self, doc, path, node):
        return self.rng.choice(ENUMS)

    def _flip(self, doc, path, node):
        return not node if isinstance(node, bool) else self.rng.choice((True, False, 0, ""))

    def _delete_key(self, doc, path, node):
        if node:
            del node[self.rng.choice(list(node))]
        return _KEEP

    def _element(self, doc, path, node):
        """An element of the list deleted, or the list cut short."""
        if node:
            start = self.rng.randrange(len(node))
            del node[start : start + (len(node) if self.rng.random() < 0.3 else 1)]
        return _KEEP

    def _expression(self, doc, path, node):
        return self.rng.choice(EXPRESSIONS)

    def _transplant(self, doc, path, node):
        """A value found elsewhere in the document (a signal name as a coefficient, a block as a target...)."""
        donor = walk(self.rng, doc)
        return copy.deepcopy(get(doc, donor)) if donor else _KEEP

    def _duplicate(self, doc, path, node):
        """The node's list gets a second copy of it (duplicate names, signals, rows)."""
        parent = get(doc, path[:-1])
        if isinstance(parent, list):
            parent.insert(self.rng.randrange(len(parent) + 1), copy.deepcopy(node))
            return _KEEP
        return copy.deepcopy(node) if not isinstance(node, list) else node + node[:1]

    def edit_history(self, doc: dict) -> None:
        """An edit of the records, the current iteration or the stored state."""
        records = doc.get("records") if isinstance(doc.get("records"), list) else []
        choice = self.rng.randrange(6)
        if choice == 0:
            doc["current_iteration"] = self.rng.choice((0, 1, len(records), len(records) + 1, -1, 10**9))
        elif choice == 1 and records:
            del records[self.rng.randrange(len(records)) :]
        elif choice == 2 and records:
            record = self.rng.choice(records)
            if (
                isinstance(record, dict)
                and isinstance(record.get("measures"), list)
                and record["measures"]
                and isinstance(record["measures"][0], dict)
            ):
                record["measures"][0]["value"] = self.rng.choice((0.0, 1e300, -1.0, "nan", "inf"))
        elif choice == 3 and isinstance(doc.get("state"), dict):
            self.mutate(doc, ("state",))
        elif choice == 4 and records:
            self.mutate(doc, ("records",))
        else:
            self.mutate(doc, ("state",) if isinstance(doc.get("state"), dict) else ())
        self.log.append(f"history edit {choice}")

    def dumps(self, doc: dict) -> str:
        """The document as JSON text, raw tokens in place."""
        text = json.dumps(doc, indent=1)
        for key, raw in self.raw.items():
            text = text.replace(json.dumps(key), raw)
        return text


_KEEP = object()


def _strings(node: Any) -> list[str]:
    """Every string value in a document."""
    if isinstance(node, str):
        return [node]
    items = node.values() if isinstance(node, dict) else node if isinstance(node, list) else ()
    return [s for child in items for s in _strings(child)]

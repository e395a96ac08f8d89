"""The checks of a session beyond its schema, made when it loads: how deeply its
JSON nests, and that its records and state read back and agree with each other
and with the problem.  Each raises `SessionError` naming the JSON path (the
caller prefixes the file)."""

from __future__ import annotations

import dataclasses
import re
from typing import Any

from pydantic import ValidationError

from engine.design.problem import Problem
from engine.errors import EngineError, shown_json
from engine.stepping.memory_fields import Fields
from engine.stepping.protocol import State, StepRecord
from engine.stepping.registry import lookup
from sessions.errors import SessionError
from sessions.format.json_diff import location
from sessions.format.schema import SessionModel

MAX_DEPTH = 64  # levels of JSON nesting a session may have (a real one has about 8)


# the union members pydantic adds to an error's location (value.float, value.list[float])
PYDANTIC_TAG = re.compile(r"^(float|int|str|bool|none|list\[.*\]|dict\[.*\]|[a-z-]+\[.*\])$")


def invalid(exc: ValueError, root: str = "", top: str = "(top)", data: Any = None) -> str:
    """A pydantic validation error as one line that names where (a JSON path under ``root``
    in ``data``, the input validated) and what, never pydantic's own dump: the first error,
    and how many more.  The path holds only the input's keys and indices: pydantic's own
    tags (a union member's type, a tagged union's tag such as ``state_space``) are left out.
    ``top`` names the place of an error of the whole value ('': what alone, as a form's one
    value says it); any other ValueError is its own text."""
    if not isinstance(exc, ValidationError):
        return str(exc)
    first = exc.errors()[0]
    loc = tuple(part for part in first["loc"] if not (isinstance(part, str) and PYDANTIC_TAG.match(part)))
    loc = _input_path(loc, data) if data is not None else loc
    where = location((root,) + loc) if root else location(loc) if loc else top
    return f"{where}: {invalid_what(exc)}" if where else invalid_what(exc)


TAGS = ("kind", "format")  # the schema's tagged unions' tag fields (`Field(discriminator=...)`)


def _input_path(loc: tuple, data: Any) -> tuple:
    """``loc`` without the tags pydantic puts in it: a tagged union's member is named by
    its tag's value (``...transfer.state_space.A``), which is no key of the input."""
    path: list = []
    node, tag_read = data, False
    for part in loc:
        if not tag_read and isinstance(node, dict) and part in [node.get(tag) for tag in TAGS]:
            tag_read = True  # the tag, once: a field of the same name may follow it
            continue
        tag_read = False
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        else:
            node = None
        path.append(part)
    return tuple(path)


def invalid_what(exc: ValidationError) -> str:
    """What is wrong, without where (`invalid`): the first error's message, how many more."""
    more = f" (and {exc.error_count() - 1} more)" if exc.error_count() > 1 else ""
    return exc.errors()[0]["msg"].removeprefix("Value error, ") + more


def check_depth(data: Any) -> None:
    """Refuse JSON nested more than `MAX_DEPTH` levels (checked without recursion,
    before pydantic or a save would recurse into it)."""
    stack: list[tuple[Any, int, tuple | None]] = [(data, 1, None)]
    while stack:
        node, depth, trail = stack.pop()
        if isinstance(node, dict):
            items: Any = node.items()
        elif isinstance(node, list):
            items = enumerate(node)
        else:
            continue
        if depth > MAX_DEPTH:
            keys = []
            while trail is not None:
                key, trail = trail
                keys.append(key)
            keys.reverse()
            shown = location(tuple(keys[:6])) + ("..." if len(keys) > 6 else "")
            raise SessionError(f"{shown}: nested more than {MAX_DEPTH} levels deep")
        stack.extend((value, depth + 1, (key, trail)) for key, value in items)


# a record's keys: its fields, and the settings that made it (sessions.runner.record_json)
RECORD_KEYS = frozenset(f.name for f in dataclasses.fields(StepRecord)) | {"settings"}


def check_records(model: SessionModel) -> None:
    """Every record reads back (`StepRecord.from_json`) and they are numbered 1..n."""
    for i, data in enumerate(model.records):
        where = f"records[{i}]"
        try:
            record = StepRecord.from_json(data, where)
        except EngineError as exc:
            raise SessionError(str(exc)) from None
        unknown = next((key for key in data if key not in RECORD_KEYS), None)
        if unknown is not None:
            raise SessionError(f"{where}.{unknown}: not a field of a record")
        if record.iteration != i + 1:
            raise SessionError(
                f"{where}.iteration: expected {i + 1} (records are numbered 1..n in order), got {record.iteration}"
            )
    if model.current_iteration > len(model.records):
        raise SessionError(f"current_iteration {model.current_iteration} exceeds the {len(model.records)} records")


def check_state(model: SessionModel) -> None:
    """A stored state is the one after the current iteration, and reads back with its
    algorithm's memory class (an unknown algorithm is reported when the session is run)."""
    if model.state is None:
        return
    try:
        iteration = Fields(model.state, "state").integer("iteration")
    except EngineError as exc:
        raise SessionError(str(exc)) from None
    if iteration != model.current_iteration:
        raise SessionError(
            f"state.iteration: {iteration}, but current_iteration is {model.current_iteration} "
            "(the state is the one after the current iteration)"
        )
    try:
        kind = lookup(model.algorithm.name).memory_type
    except EngineError:
        return
    try:
        State.from_json(model.state, kind)
    except EngineError as exc:
        raise SessionError(f"state: {exc}") from None


def check_record_parameters(model: SessionModel, problem: Problem) -> None:
    """A record's parameters are the problem's: a number each, a list of one per condition
    for a parameter with a value per condition."""
    lengths = {p.name: len(p.value) if p.per_condition else None for p in problem.parameters}
    for i, data in enumerate(model.records):
        for name, value in data["parameters"].items():
            where = f"records[{i}].parameters.{name}"
            if name not in lengths:
                raise SessionError(f"{where}: not a parameter of the problem")
            n = lengths[name]
            if n is None and isinstance(value, list):
                raise SessionError(
                    f"{where}: expected a number ({name} has one value for all conditions), got a list of {len(value)}"
                )
            if n is not None and not (isinstance(value, list) and len(value) == n):
                got = f"a list of {len(value)}" if isinstance(value, list) else shown_json(value)
                raise SessionError(f"{where}: expected a list of {n} numbers (one per condition), got {got}")

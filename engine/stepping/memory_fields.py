"""JSON numbers and algorithm memories: `finite_or_none` is a number as JSON output holds
it, `jsonable` writes plain JSON types, `Fields`
reads them back and rejects malformed data with an `EngineError` that names
the field and what was expected (a missing field, a string where a number was
wanted, a list of the wrong length, a non-finite number where a finite one is
required).  Non-finite floats are written as the strings 'inf', '-inf', 'nan'.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from enum import Enum
from typing import Any

from engine.errors import EngineError, shown_json

NON_FINITE = ("inf", "-inf", "nan")


def finite_or_none(value: object) -> float | None:
    """A number as JSON output holds it: a finite float, else None (JSON has no infinities;
    a number kept as text, 'inf' or 'nan', reads as what it says)."""
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def jsonable(value: Any) -> Any:
    """Plain JSON types; non-finite floats become the strings 'inf', '-inf', 'nan'."""
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, Enum):
        return value.value
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if hasattr(value, "tolist"):
        return jsonable(value.tolist())
    return value


def to_float(value: Any, where: str, finite: bool = True) -> float:
    """A JSON number (or 'inf'/'-inf'/'nan') as a float; ``finite``: those strings are refused."""
    if isinstance(value, str) and value in NON_FINITE:
        value = float(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise EngineError(f"{where}: expected a {'finite ' if finite else ''}number, got {shown_json(value)}")
    try:
        number = float(value)
    except OverflowError:  # a JSON integer beyond a float's range
        raise EngineError(
            f"{where}: expected a number within a float's range, got an integer of {len(str(abs(value)))} digits"
        ) from None
    if finite and not math.isfinite(number):
        raise EngineError(f"{where}: expected a finite number, got {number!r}")
    return number


class Fields:
    """Typed reading of a JSON object's fields; errors name ``where`` and the field."""

    def __init__(self, data: Any, where: str):
        if not isinstance(data, Mapping):
            raise EngineError(f"{where}: expected an object, got {shown_json(data)}")
        self.data, self.where = data, where

    def _name(self, name: str) -> str:
        return f"{self.where}.{name}"

    def get(self, name: str) -> Any:
        """The raw value of a field that must be present."""
        if name not in self.data:
            raise EngineError(f"{self._name(name)}: missing")
        return self.data[name]

    def number(self, name: str, finite: bool = True) -> float:
        """A float field."""
        return to_float(self.get(name), self._name(name), finite)

    def optional_number(self, name: str, finite: bool = True) -> float | None:
        """A float field that may be null."""
        return None if self.get(name) is None else self.number(name, finite)

    def integer(self, name: str, minimum: int | None = 0) -> int:
        """An integer field (at least ``minimum``)."""
        value = self.get(name)
        if isinstance(value, bool) or not isinstance(value, int) or (minimum is not None and value < minimum):
            bound = "" if minimum is None else f" >= {minimum}"
            raise EngineError(f"{self._name(name)}: expected an integer{bound}, got {shown_json(value)}")
        return value

    def boolean(self, name: str) -> bool:
        """A true/false field."""
        value = self.get(name)
        if not isinstance(value, bool):
            raise EngineError(f"{self._name(name)}: expected true or false, got {shown_json(value)}")
        return value

    def text(self, name: str) -> str:
        """A string field."""
        value = self.get(name)
        if not isinstance(value, str):
            raise EngineError(f"{self._name(name)}: expected a string, got {shown_json(value)}")
        return value

    def items(self, name: str, length: int | None = None) -> list:
        """A list field (of ``length`` items when given)."""
        value = self.get(name)
        if not isinstance(value, list):
            raise EngineError(f"{self._name(name)}: expected a list, got {shown_json(value)}")
        if length is not None and len(value) != length:
            raise EngineError(f"{self._name(name)}: expected {length} items, got {len(value)}")
        return value

    def numbers(self, name: str, length: int | None = None, finite: bool = True) -> tuple[float, ...]:
        """A list of floats."""
        return tuple(to_float(v, f"{self._name(name)}[{i}]", finite) for i, v in enumerate(self.items(name, length)))

    def matrix(
        self, name: str, rows: int | None = None, columns: int | None = None, finite: bool = True
    ) -> tuple[tuple[float, ...], ...]:
        """A list of equally long lists of floats."""
        out = []
        for i, row in enumerate(self.items(name, rows)):
            where = f"{self._name(name)}[{i}]"
            if not isinstance(row, list) or (columns is not None and len(row) != columns):
                wanted = "a list" if columns is None else f"a list of {columns} numbers"
                got = f"{len(row)} numbers" if isinstance(row, list) else shown_json(row)
                raise EngineError(f"{where}: expected {wanted}, got {got}")
            out.append(tuple(to_float(v, f"{where}[{j}]", finite) for j, v in enumerate(row)))
            columns = len(row)
        return tuple(out)

    def object(self, name: str) -> Fields:
        """A nested object field."""
        return Fields(self.get(name), self._name(name))

    def objects(self, name: str) -> list[Fields]:
        """A list of objects."""
        return [Fields(v, f"{self._name(name)}[{i}]") for i, v in enumerate(self.items(name))]

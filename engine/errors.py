"""Typed errors raised by the engine; every message names what and where."""

import json
from typing import Any


class EngineError(ValueError):
    """Base class of every error the engine raises on bad input."""


class ExpressionError(EngineError):
    """An expression could not be parsed or evaluated.

    ``position`` is the 0-based column of the offending token (or None).
    """

    def __init__(self, message: str, expression: str = "", position: int | None = None):
        self.expression = expression
        self.position = position
        where = f" at column {position + 1}" if position is not None else ""
        super().__init__(f"{message}{where} in {expression!r}" if expression else message)


class BlockError(EngineError):
    """A block is ill-formed: improper, zero denominator, bad data table."""


class GridError(EngineError):
    """A frequency grid is empty, non-finite or not strictly increasing."""


class ExtrapolationError(EngineError):
    """Tabulated data was asked for outside the frequencies it covers."""


class InterconnectionError(EngineError):
    """A diagram or matrix is inconsistent: unknown signals, duplicate
    definitions, or a singular interconnection at some frequency."""


class ParameterError(EngineError):
    """A parameter is unknown, missing a value, or not finite."""


def shown_json(value: Any) -> str:
    """A value read from JSON as a message shows it: its kind and its JSON text (``a list
    [true]``, ``null``, ``the string "x"``), never Python's repr, at most 40 characters."""
    try:
        text = json.dumps(value, default=str)
    except (TypeError, ValueError, RecursionError):
        text = str(value)
    text = text if len(text) <= 40 else text[:37] + "..."
    if value is None or isinstance(value, bool):
        return text
    kinds = ((str, "the string"), ((list, tuple), "a list"), (dict, "an object"), ((int, float), "the number"))
    return f"{next((name for types, name in kinds if isinstance(value, types)), 'a value')} {text}"

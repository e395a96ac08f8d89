"""Typed errors raised by the engine; every message names what and where, and quotes
what it refuses shortened (`shown`, a value read from JSON as JSON: `shown_json`)."""

import json
from typing import Any

SHOWN = 40  # characters of a value a message quotes


def shortened(text: str, most: int = SHOWN, mark: str = "...") -> str:
    """``text`` as a message quotes it: at most ``most`` characters, its end replaced by ``mark``
    when it is cut."""
    return text if len(text) <= most else text[: most - len(mark)] + mark


def shown(value: object, most: int = SHOWN, typed: bool = False) -> str:
    """A value as a message quotes it: its repr shortened (`shortened`); ``typed``: after its
    type's name (a JSON field that holds the wrong kind of value)."""
    text = shortened(repr(value), most)
    return f"{type(value).__name__} {text}" if typed else text


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
    text = shortened(text)
    if value is None or isinstance(value, bool):
        return text
    kinds = ((str, "the string"), ((list, tuple), "a list"), (dict, "an object"), ((int, float), "the number"))
    return f"{next((name for types, name in kinds if isinstance(value, types)), 'a value')} {text}"

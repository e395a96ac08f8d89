"""The one error type session code raises on bad input, and how long a message shown may be."""

import re


class SessionError(ValueError):
    """A session cannot be read, built, saved or replayed; the message says where and why."""


SHOWN_QUOTE = 200  # characters of a quoted input shown in a message before it is cut
SHOWN_LINE = 1000  # characters of any line of a message (paths and all)
_QUOTED = re.compile(rf"'[^'\n]{{{SHOWN_QUOTE + 1},}}'|\"[^\"\n]{{{SHOWN_QUOTE + 1},}}\"")


def bounded_message(text: str) -> str:
    """A message as shown to the user: an echoed input longer than `SHOWN_QUOTE` (a quoted
    200 000 characters) cut to its start and end around an ellipsis that says how long it
    was (``'aaaa ... [200017 characters] ... aaa'``), and any line to `SHOWN_LINE`."""
    text = _QUOTED.sub(lambda m: m[0][0] + cut(m[0][1:-1], SHOWN_QUOTE) + m[0][-1], text)
    return "\n".join(cut(line, SHOWN_LINE) for line in text.split("\n"))


def cut(text: str, most: int) -> str:
    """``text``, or when longer than ``most`` characters its start and end around
    ``... [N characters] ...``."""
    if len(text) <= most:
        return text
    head, tail = most * 3 // 4, most // 4
    return f"{text[:head]} ... [{len(text)} characters] ... {text[-tail:]}"


def in_words(exc: BaseException) -> str:
    """What went wrong, in one line of words: an exception's message (a library's example on
    a line of its own joined), never its Python type's name; a message-less exception its
    type's words ("ZeroDivisionError" -> "zero division")."""
    text = " ".join(str(exc).split())
    if text:
        return text
    words = re.sub(r"(?<!^)(?=[A-Z])", " ", type(exc).__name__.removesuffix("Error")).lower()
    return words or "failed"

"""What the command line's modules share: their error, and JSON numbers."""

from __future__ import annotations

import math


class CliError(Exception):
    """Bad input on the command line: printed as one line, exit status 2."""


def finite_or_none(x: float | None) -> float | None:
    """A finite float, else None (JSON has no infinities)."""
    return None if x is None or not isinstance(x, (int, float)) or not math.isfinite(x) else float(x)

"""The session format's size limits and number types (docs/session-format.md).

A session beyond a limit is refused when it loads, naming the JSON path; one
within them finishes `loopcraft report` in seconds.  Numbers are finite
wherever infinity or NaN means nothing; a few fields read an infinity as "no
limit" (a parameter's ``min`` -inf and ``max`` +inf, a band's ``high``, a
target's ``detect_high``), and NaN nowhere.
"""

from __future__ import annotations

import re
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, Field

from engine.errors import shortened, shown_json
from engine.model.blocks import (
    MAX_TABLE_ROWS as MAX_TABLE_ROWS,  # rows of a table, inline or CSV: the engine's one limit
)
from engine.model.ports.state_space_ports import (
    MAX_PORTS as MAX_PORTS,  # input (and output) ports of a state-space block: the engine's one limit
)
from engine.model.state_space import (
    MAX_STATES as MAX_STATES,  # states of a state-space block, inline or from a file: the engine's one limit
)

MAX_CONDITIONS = 100
MAX_BREAKS = 64  # loop breaks of one condition (its `breaks`)
MAX_BLOCKS = 1000  # blocks of a diagram, entries of a matrix, compensators of a channel
MAX_SIGNALS = 1000  # inputs of a diagram, its junctions, the signals of a matrix
MAX_JUNCTION_INPUTS = 100  # signals into one junction (plus and minus each)
MAX_CHANNELS = 100
MAX_FACTORS = 100  # factors of one factored or controller block
MAX_COEFFICIENTS = 65  # of one polynomial: degree 64, the largest power an expression takes
MAX_PARAMETERS = 1000  # parameters, and terms of one equality
MAX_TARGETS = 1000
MAX_BANDS = 100  # bands of a target (and its push/pull points, a response's profile segments)
MAX_GRID_POINTS = 100_000  # a grid's points or explicit values
MAX_RESPONSE_POINTS = 100_000  # time points of a time response
MAX_EQUALITIES = 1000
MAX_CONSTRAINTS = 1000  # linear inequalities between parameters (1000 characters each)
MAX_OPTIONS = 100  # options, tables of an objective
MAX_NYQUIST = 1e306  # rad/s: a sample time T must keep pi/T (and the grid below it) within double precision
MAX_SESSION_BYTES = 256 * 2**20  # a session file (its records included), read with a bounded read
MAX_STARTS = 100_000  # runs of a multi-start sweep: each a copy of the session, each run kept
MAX_SAMPLES = 1_000_000  # of a tolerance study: over 10 000 its distributions are kept, not its runs

Number = Annotated[float, Field(allow_inf_nan=False)]
MAX_NAME = 200  # characters of a name (a parameter's, a block's, a signal's)
Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=MAX_NAME)]


def _coefficient(value: Any) -> Any:
    """A finite number or a parameter's name, with a message that says so."""
    if isinstance(value, str):
        if value.strip().lower() in ("nan", "inf", "-inf", "+inf", "infinity", "-infinity"):
            raise ValueError(f"a coefficient must be finite, not {value!r}")
        if not IDENTIFIER.fullmatch(value):
            raise ValueError(
                f"a coefficient is a number or a parameter name, not {shortened(value)!r} "
                "(an expression belongs in an expression block)"
            )
    elif isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"a coefficient is a number or a parameter name, not {shown_json(value)}")
    return value


IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
Coefficient = Annotated[Number | Name, BeforeValidator(_coefficient)]  # a number or a parameter name


def bounded(list_type: Any, most: int, least: int = 0) -> Any:
    """A list (or dict) type of ``least`` to ``most`` items."""
    return Annotated[list_type, Field(min_length=least, max_length=most)]


def _limit(refused: float) -> Any:
    """A float that may be infinite (no limit) but is neither NaN nor ``refused``."""

    def check(x: float) -> float:
        if x != x:
            raise ValueError("must be a number, not NaN")
        if x == refused:
            raise ValueError(f"must not be {refused}")
        return x

    return Annotated[float, AfterValidator(check)]


Upper = _limit(float("-inf"))  # an upper limit: +inf is no limit
Lower = _limit(float("inf"))  # a lower limit: -inf is no limit

"""One entry to every export format: a session's design at an iteration as the
text of a python-control script, a MATLAB script, JSON data or a CSV response
(`loopcraft export` and the app's export menu both call `export_text`)."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the command line reads SUFFIX to build its parser: no schema import at start
    from sessions.store import Session

SUFFIX = {"python": ".py", "matlab": ".m", "json": ".export.json", "csv": ".csv"}
FORMATS = {
    "python": "a python-control script that rebuilds the loop and prints its margins",
    "matlab": "a MATLAB script (tf/zpk/connect)",
    "json": "compensators (coefficients, zeros, poles, gain) and the loop's state space",
    "csv": "the open and closed loop's frequency response on the session's grid",
}


def export_text(session: Session, iteration: int | None, to: str, sample_time: float | None = None) -> str:
    """The exported text of the design at ``iteration`` (None: the session's current one)."""
    from sessions.export.design_model import design

    if to not in SUFFIX:
        raise ValueError(f"unknown export format {to!r}; formats: {', '.join(SUFFIX)}")
    d = design(session, iteration)
    if to == "python":
        from sessions.export.python_script import python_script

        return python_script(d, sample_time)
    if to == "matlab":
        from sessions.export.matlab import matlab_script

        return matlab_script(d, sample_time)
    if to == "json":
        from sessions.export.data import design_json

        return json.dumps(design_json(d, sample_time), indent=2, allow_nan=False) + "\n"
    from sessions.export.data import response_csv

    return response_csv(session, d)

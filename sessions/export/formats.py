"""One entry to every export format: a session's design at an iteration as the
text of a python-control script, a MATLAB script, JSON data or a CSV response
(`loopcraft export` and the app's export menu both call `export_text`)."""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the command line reads SUFFIX to build its parser: no schema import at start
    from sessions.export.design_model import Design
    from sessions.store import Session

SUFFIX = {"python": ".py", "matlab": ".m", "json": ".export.json", "csv": ".csv"}
FORMATS = {
    "python": "a python-control script that rebuilds the loop and prints its margins",
    "matlab": "a MATLAB script (tf/zpk/connect)",
    "json": "compensators (coefficients, zeros, poles, gain) and the loop's state space",
    "csv": "the open and closed loop's frequency response on the session's grid",
}


def export_text(
    session: Session, iteration: int | None, to: str, sample_time: float | None = None, fit: bool = False
) -> str:
    """The exported text of the design at ``iteration`` (None: the session's current one);
    ``fit``: tables as their rational fits (checked) rather than as tables."""
    from sessions.export.design_model import design

    if to not in SUFFIX:
        raise ValueError(f"unknown export format {to!r}; formats: {', '.join(SUFFIX)}")
    d = design(session, iteration, fit)
    if to == "python":
        from sessions.export.python_script import python_script

        return python_script(d, sample_time, loopcraft_margins(session, d))
    if to == "matlab":
        from sessions.export.matlab import matlab_script

        return matlab_script(d, sample_time)
    if to == "json":
        from sessions.export.data import design_json

        return json_text(design_json(d, sample_time))
    from sessions.export.data import response_csv

    return response_csv(session, d)


def loopcraft_margins(session: Session, d: Design) -> dict[str, dict]:
    """loopcraft's gain margins (dB, rad/s) and phase margins (deg, rad/s) of each
    condition at the design, and how they were obtained, for the script to print."""
    from engine.errors import EngineError
    from engine.loop.responses import loop_model
    from engine.margins.search import margins

    out = {}
    for c, condition in zip(session.problem.conditions, d.conditions):
        try:
            found = margins(loop_model(c.network, c.break_at, session.problem.grid.omega, condition.values))
        except EngineError as exc:
            out[c.name] = {"method": f"not found: {exc}"}
            continue
        out[c.name] = _margin_lists(found)
        if condition.breaks:
            out[c.name].update(_at_breaks(c, condition.breaks, session.problem.grid.omega, condition.values))
    return out


def _margin_lists(found) -> dict:
    return {
        "method": found.label,
        "gain": [(float(m.gain_db), float(m.frequency)) for m in found.gain if m.gain_db is not None],
        "phase": [(float(m.phase_deg), float(m.frequency)) for m in found.phase if m.phase_deg is not None],
    }


def _at_breaks(c, breaks: tuple[str, ...], omega, values: dict) -> dict:
    """loopcraft's margins and disk margin at each break (the others closed) and the certified
    multi-loop disk margin, for the script to print beside python-control's (None: not found)."""
    from engine.multiloop.diagram_breaks import diagram_breaks

    found = diagram_breaks(c.network, breaks, omega, values)
    each = {}
    for b in found.loops:
        if b.margins is None:
            each[b.name] = {"method": f"not found: {b.failure}"}
            continue
        disk = b.disk_margin
        each[b.name] = _margin_lists(b.margins) | {"disk": None if disk is None else float(disk.alpha)}
    together = None if found.together is None else float(found.together.alpha)
    return {"breaks": each, "multi_loop": together}


def json_text(data: object) -> str:
    """Exported JSON data as text; a non-finite number is a `SessionError` naming its
    place in the data (``conditions[0].open_loop.A[1][0]: inf``: JSON has no infinities)."""
    try:
        return json.dumps(data, indent=2, allow_nan=False) + "\n"
    except ValueError:
        from sessions.errors import SessionError

        where = first_non_finite(data, "") or "a number"
        raise SessionError(f"{where}: not finite (inf or NaN) at this design; JSON has neither") from None


def first_non_finite(data: object, path: str) -> str | None:
    """The path of the first float in ``data`` that is inf or NaN, or None."""
    if isinstance(data, float):
        return None if math.isfinite(data) else path
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list | tuple) else ()
    for key, value in items:
        found = first_non_finite(value, f"{path}.{key}" if isinstance(key, str) else f"{path}[{key}]")
        if found is not None:
            return found.lstrip(".")
    return None

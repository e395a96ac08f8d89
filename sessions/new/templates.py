"""New sessions from a plant and a compensator structure: the one source of the
templates (`loopcraft new` and the app's new-session dialog both call
`new_session`).

The session is a unity-feedback loop r -> e -> compensator -> u -> plant -> y,
e = r - y, broken at e; a delay factor ``exp(-T*s)`` of the plant becomes a
delay block.  The compensator's parameters come from its structure with
bounds: time constants positive within [1e-4, 1e4] s, gains within
[1e-6, 1e6]; the targets are PM >= 45 deg and GM >= 6 dB in every condition
(5 deg of phase margin count as 1 dB of gain margin in slp's figure of merit,
as in the bundled examples).  The grid spans two decades beyond the plant's
corner frequencies.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import TYPE_CHECKING

from engine.errors import EngineError
from sessions.errors import SessionError
from sessions.format.limits import MAX_NYQUIST

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

LOOPCRAFT_VERSION = "0.1.0"
TIME_CONSTANT = (1e-4, 1e4)
GAIN = (1e-6, 1e6)

# structure -> (expression, {parameter: starting value}); K a gain, T... time constants
STRUCTURES: dict[str, tuple[str, dict[str, float]]] = {
    "gain": ("K", {"K": 1.0}),
    "lead": ("K*(1+T1*s)/(1+T2*s)", {"K": 1.0, "T1": 1.0, "T2": 0.1}),
    "lag": ("K*(1+T1*s)/(1+T2*s)", {"K": 1.0, "T1": 1.0, "T2": 10.0}),
    "lead-lag": ("K*(1+T1*s)*(1+T3*s)/((1+T2*s)*(1+T4*s))", {"K": 1.0, "T1": 1.0, "T2": 0.1, "T3": 10.0, "T4": 100.0}),
    "pi": ("K*(1+Ti*s)/(Ti*s)", {"K": 1.0, "Ti": 1.0}),
    "pid": ("K*(1+1/(Ti*s)+Td*s/(1+0.1*Td*s))", {"K": 1.0, "Ti": 1.0, "Td": 0.1}),
}


# a lead's or lag's zero and pole at most a factor 20 apart (1/20 <= T1/T2 <= 20): linear
# constraints the new session carries, which the engineer sees in the Targets tab and may delete
# (without them an optimizer may put a pole at the bound, 1e4 rad/s, and amplify noise)
RATIO = 20
STRUCTURE_CONSTRAINTS: dict[str, list[str]] = {
    "lead": [f"T1 <= {RATIO}*T2", f"T2 <= {RATIO}*T1"],
    "lag": [f"T1 <= {RATIO}*T2", f"T2 <= {RATIO}*T1"],
    "lead-lag": [f"T1 <= {RATIO}*T2", f"T2 <= {RATIO}*T1", f"T3 <= {RATIO}*T4", f"T4 <= {RATIO}*T3"],
}


def new_session(
    plant: str | dict,
    compensator: str = "lead",
    algorithm: str | None = None,
    *,
    name: str = "nominal",
    notes: str = "",
    grid: dict | None = None,
    sample_time: float | None = None,
    discretize: str = "zoh",
) -> dict:
    """A valid session (JSON data `sessions.store.parse_session` accepts) designing
    ``compensator`` (a name of `STRUCTURES` or an expression in s, or w, whose other
    names become parameters) for ``plant`` (an expression in s, or w for a w-plane
    loop, numbers only, delay factors exp(-T*s) allowed; or a block's ``transfer``
    JSON, e.g. a table, with its ``grid``) with ``algorithm`` (one that offers new sessions,
    `new_session_algorithms`; None: the first).  ``name``
    names the flight condition.  With ``sample_time`` (s) the loop is in z (`sampled_session`).
    Bad input is a `SessionError` naming it."""
    from engine.stepping.registry import new_session_algorithms  # here: `loopcraft new --help` stays light
    from sessions.format.schema import SCHEMA_VERSION

    offered = new_session_algorithms()
    algorithm = offered[0] if algorithm is None else algorithm
    if algorithm not in offered:
        raise SessionError(
            f"algorithm {algorithm!r}: a new session is made for {' or '.join(offered)} "
            "(the others need an objective of their own)"
        )
    if sample_time is not None:
        return sampled_session(
            new_session(plant, compensator, algorithm, name=name, notes=notes, grid=grid), sample_time, discretize
        )
    if isinstance(plant, dict):
        plant_text, delay, variable = "", 0.0, "s"
    else:
        plant_text, delay, variable = read_plant(plant)
    expression, starts = read_compensator(compensator, variable)
    blocks = [_block("compensator", "e", "u", expression)]
    if isinstance(plant, dict):
        blocks.append({"name": "plant", "input": "u", "output": "y", "transfer": plant})
    elif delay > 0:
        blocks += [
            _block("plant", "u", "y0", plant_text),
            {"name": "delay", "input": "y0", "output": "y", "transfer": {"kind": "delay", "tau": delay}},
        ]
    else:
        blocks.append(_block("plant", "u", "y", plant_text))
    stamp = datetime.now(UTC).replace(microsecond=0).isoformat()
    condition = {
        "name": name,
        "variable": variable,
        "break_at": "e",
        "plant": {
            "format": "diagram",
            "inputs": ["r"],
            "blocks": blocks,
            "junctions": [{"name": "sum", "output": "e", "plus": ["r"], "minus": ["y"]}],
        },
    }
    return {
        "schema_version": SCHEMA_VERSION,
        "provenance": {"loopcraft_version": LOOPCRAFT_VERSION, "created": stamp, "modified": stamp},
        "notes": notes
        or f"A new session: the compensator {expression} ({compensator}) on the plant "
        f"{plant_text or plant['kind'].replace('_', ' ')}, unity feedback; targets PM >= 45 deg, GM >= 6 dB.",
        "problem": {
            "grid": grid or grid_for(plant_text, variable),
            "conditions": [condition],
            "parameters": [parameter_entry(p, v) for p, v in starts.items()],
            "targets": [
                {"measure": "phase_margin_deg", "bands": [{"desired": 45.0}], "scale": 0.2},
                {"measure": "gain_margin_db", "bands": [{"desired": 6.0}]},
            ],
            **(
                {"constraints": list(STRUCTURE_CONSTRAINTS[compensator])}
                if compensator in STRUCTURE_CONSTRAINTS
                else {}
            ),
        },
        "algorithm": {"name": algorithm, "settings": {}},
        "records": [],
        "current_iteration": 0,
        "state": None,
    }


def sampled_session(data: dict, sample_time: float, discretize: str = "zoh") -> dict:
    """A new session's loop in z, every ``sample_time`` s: a plant in s discretized on the way in
    (``discretize``: zoh, exact, its delay as whole and fractional samples; tustin; matched), a plant
    typed in z kept; the compensator's structure by Tustin's map s = (2/T)(z - 1)/(z + 1), its
    parameters keeping their meaning (time constants in s, gains); the grid up to the Nyquist
    frequency pi/T."""

    from engine.model.expressions import substituted

    if not (math.isfinite(sample_time) and sample_time > 0):
        raise SessionError(f"--sample-time: {sample_time!r} must be a finite number of seconds > 0")
    condition = data["problem"]["conditions"][0]
    if condition["variable"] == "w":
        raise SessionError("--sample-time: the plant is in s (discretized) or in z, not a w-plane loop")
    typed_in_z = condition["variable"] == "z"
    blocks = condition["plant"]["blocks"]
    delay = next((b["transfer"]["tau"] for b in blocks if b["transfer"]["kind"] == "delay"), 0.0)
    blocks[:] = [b for b in blocks if b["transfer"]["kind"] != "delay"]
    tustin = f"({2.0 / sample_time!r}*(z-1)/(z+1))"
    for b in blocks:
        t = b["transfer"]
        if t["kind"] != "expression":
            raise SessionError(f"--sample-time: a {t['kind']} plant is not discretized (give it as an expression)")
        if b["name"] == "compensator":
            if not _reads_in_z(t["expression"]):  # a structure, written in s
                t["expression"] = substituted(t["expression"], "s", tustin)
        elif not typed_in_z:
            b["transfer"] = {"kind": "discretized", "expression": t["expression"], "method": discretize}
            if delay:
                b["transfer"]["delay"] = delay
        b["output"] = "y" if b["name"] == "plant" else b["output"]
    condition.update(variable="z", sample_time=sample_time)
    nyquist = math.pi / sample_time
    if sample_time * MAX_NYQUIST < math.pi:
        raise SessionError(f"--sample-time {sample_time:g}: its Nyquist frequency pi/T is beyond 1e306 rad/s")
    data["problem"]["grid"] = {
        "unit": "rad/s",
        "start": _round(nyquist * 1e-4),
        "stop": nyquist * 0.999,
        "points": 400,
        "spacing": "log",
    }
    data["notes"] += f" Sampled every {sample_time:g} s" + (
        "." if typed_in_z else f": the plant by {discretize}, the compensator by Tustin's map."
    )
    return data


def _reads_in_z(text: str) -> bool:
    from engine.model.expressions import Expression

    try:
        Expression(text, "z")
    except EngineError:
        return False
    return True


def _block(name: str, source: str, output: str, expression: str) -> dict:
    return {
        "name": name,
        "input": source,
        "output": output,
        "transfer": {"kind": "expression", "expression": expression},
    }


def read_plant(plant: str) -> tuple[str, float, str]:
    """The plant's rational part, its delay and its variable; numbers only."""
    from engine.analysis import check_not_zero, split_delays  # on use: the command line's parser reads STRUCTURES
    from engine.model.blocks import ExpressionTransfer
    from engine.model.expressions import Expression

    try:
        text, delay = split_delays(plant.strip())
        variable, names = "s", Expression(text, "s").parameters
    except EngineError as exc:
        variable, names, text, delay = _other_variable(plant.strip(), exc)
    if names:
        raise SessionError(
            f"--plant: {plant!r} names {', '.join(sorted(names))}: a plant has numbers and the variable s "
            "(or w, or z) only"
        )
    try:
        check_not_zero(ExpressionTransfer(text, variable), "--plant")
    except EngineError as exc:
        raise SessionError(str(exc)) from None
    return text, delay, variable


def _other_variable(text: str, failed: EngineError) -> tuple[str, tuple[str, ...], str, float]:
    """A plant that does not read in s: in w (a w-plane loop) or in z (a sampled loop, its sample time
    given beside it); no delay.  Else `failed`, as a `SessionError`."""
    from engine.model.expressions import Expression

    for variable in ("w", "z"):
        try:
            return variable, Expression(text, variable).parameters, text, 0.0
        except EngineError:
            continue
    raise SessionError(f"--plant: {failed}") from None


def read_compensator(compensator: str, variable: str) -> tuple[str, dict[str, float]]:
    """The compensator's expression (in ``variable``) and its parameters' starting values."""
    from engine.model.expressions import Expression

    if compensator in STRUCTURES:
        expression, starts = STRUCTURES[compensator]
        # in s; a w-plane loop reads it in w; a loop in z maps it by Tustin (`sampled_session`)
        return (expression.replace("s", variable) if variable == "w" else expression), dict(starts)
    try:
        names = Expression(compensator, variable).parameters
    except EngineError as exc:
        raise SessionError(f"--compensator: {exc} (or one of {', '.join(STRUCTURES)})") from None
    if not names:
        raise SessionError(
            f"--compensator: {compensator!r} has no parameter to design (structures: {', '.join(STRUCTURES)})"
        )
    return compensator, {n: 1.0 for n in sorted(names)}


def parameter_entry(name: str, value: float) -> dict:
    """Time constants (T...) and gains (K...) positive and bounded; others within +-1e6."""
    if name[0] in "Tt":
        low, high = TIME_CONSTANT
    elif name[0] in "Kk":
        low, high = GAIN
    else:
        return {"name": name, "value": value, "min": -GAIN[1], "max": GAIN[1]}
    return {"name": name, "value": min(max(value, low), high), "min": low, "max": high, "sign": "positive"}


def grid_for(plant: str, variable: str) -> dict:
    """Log grid two decades beyond the plant's nonzero corner frequencies (0.01..1000 without any)."""
    import numpy as np

    from engine.model.expressions import Expression
    from engine.model.factored import pole_zero

    try:
        form = pole_zero(Expression(plant, variable), {})
        roots = np.concatenate([form.zeros, form.poles])
    except EngineError:
        roots = np.zeros(0)
    return corner_grid(roots)


def corner_grid(roots: NDArray[np.complex128]) -> dict:
    """Log grid two decades beyond the nonzero roots' frequencies (0.01..1000 without any)."""
    import numpy as np

    corners = np.abs(roots)
    corners = corners[(corners > 0) & np.isfinite(corners)]
    low = float(np.clip(corners.min() / 100, 1e-6, 1e3)) if corners.size else 0.01
    high = float(np.clip(corners.max() * 100, low * 1e3, 1e8)) if corners.size else 1000.0
    return {"unit": "rad/s", "start": _round(low), "stop": _round(high), "points": 400, "spacing": "log"}


def _round(x: float) -> float:
    """A power of ten at or beyond x (grid edges read better)."""
    return float(10.0 ** math.floor(math.log10(x))) if x < 1 else float(10.0 ** math.ceil(math.log10(x)))

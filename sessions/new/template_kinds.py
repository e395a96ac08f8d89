"""The kinds of new session the app offers, beside `sessions.new.templates`'s unity
feedback loop: two nested loops, a tabulated plant from a CSV file, the same
loop in COEBRA's matrix format, and a constrained DAE.  Each returns
session JSON data that `sessions.store.parse_session` accepts."""

from __future__ import annotations

import json
import math
from pathlib import Path

from sessions.errors import SessionError
from sessions.new.templates import grid_for, new_session, parameter_entry, read_compensator, read_plant

KINDS: dict[str, str] = {
    "unity": "unity feedback: a plant and a compensator (PM >= 45 deg, GM >= 6 dB)",
    "two-loops": "two loops: an inner plant and compensator inside an outer loop (margins at both)",
    "table": "a tabulated plant: a frequency response from a CSV file",
    "matrix": "a matrix-format plant: the unity loop as COEBRA's A(s) x = B r",
    "dae": "a constrained DAE: report 004's integrator example, designed by alternating projections",
    "digital": "a digital loop in z: a sample time, a plant in s (held: zero-order hold) or in z, a compensator",
}
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def in_unit(data: dict, unit: str) -> dict:
    """The session with its grid in ``unit`` ('hz' or 'rad/s'), the same frequencies."""
    grid = data["problem"]["grid"]
    if grid.get("unit", "rad/s") == unit or "start" not in grid:
        return data
    factor = 1 / (2 * math.pi) if unit == "hz" else 2 * math.pi
    grid.update(unit=unit, start=grid["start"] * factor, stop=grid["stop"] * factor)
    return data


def _renamed(expression: str, starts: dict[str, float], suffix: str) -> tuple[str, dict[str, float]]:
    """The compensator's parameters with a suffix (K -> K_o), so two compensators do not share them."""
    from engine.model.expressions import substituted  # on use: the command line's parser reads KINDS

    for name in sorted(starts, key=len, reverse=True):
        expression = substituted(expression, name, name + suffix)
    return expression, {name + suffix: value for name, value in starts.items()}


def two_loop_session(
    inner_plant: str, outer_plant: str, inner: str = "pi", outer: str = "lead", algorithm: str | None = None
) -> dict:
    """r -> e1 -> outer compensator -> x_ref -> e2 -> inner compensator -> u -> inner plant -> x
    -> outer plant -> y, e1 = r - y, e2 = x_ref - x; one condition broken at e1 (the outer
    loop, the inner one closed) and one at e2 (the inner loop), the same targets at both."""
    data = new_session(inner_plant, inner, algorithm)
    inner_text, _, variable = read_plant(inner_plant)
    outer_text, _, outer_variable = read_plant(outer_plant)
    if outer_variable != variable:
        raise SessionError("the two plants must be in the same variable (s or w)")
    c_in, p_in = _renamed(*read_compensator(inner, variable), "_i")
    c_out, p_out = _renamed(*read_compensator(outer, variable), "_o")

    def block(name: str, source: str, output: str, expression: str) -> dict:
        return {
            "name": name,
            "input": source,
            "output": output,
            "transfer": {"kind": "expression", "expression": expression},
        }

    plant = {
        "format": "diagram",
        "inputs": ["r"],
        "blocks": [
            block("outer compensator", "e1", "x_ref", c_out),
            block("inner compensator", "e2", "u", c_in),
            block("inner plant", "u", "x", inner_text),
            block("outer plant", "x", "y", outer_text),
        ],
        "junctions": [
            {"name": "outer sum", "output": "e1", "plus": ["r"], "minus": ["y"]},
            {"name": "inner sum", "output": "e2", "plus": ["x_ref"], "minus": ["x"]},
        ],
    }
    problem = data["problem"]
    problem["conditions"] = [
        {"name": f"{loop} loop", "variable": variable, "break_at": point, "plant": plant}
        for loop, point in (("outer", "e1"), ("inner", "e2"))
    ]
    problem["parameters"] = [parameter_entry(n, v) for n, v in {**p_out, **p_in}.items()]
    problem["grid"] = grid_for(f"({inner_text})*({outer_text})", variable)
    data["notes"] = (
        f"Two loops: the inner compensator {c_in} around {inner_text}, the outer {c_out} around "
        f"{outer_text}; margins at both break points (conditions 'outer loop' at e1, 'inner loop' at e2)."
    )
    return data


def matrix_session(plant: str, compensator: str = "lead", algorithm: str | None = None) -> dict:
    """The unity-feedback loop of `new_session` written in the matrix format: signals
    e, u, y with e + y = r, u - C e = 0, y - P u = 0 (forcing r in the first row)."""
    data = new_session(plant, compensator, algorithm)
    condition = data["problem"]["conditions"][0]
    blocks = {b["name"]: b for b in condition["plant"]["blocks"]}
    if "delay" in blocks:
        raise SessionError("a matrix-format plant is rational: write the delay in a diagram (unity feedback)")
    c = blocks["compensator"]["transfer"]["expression"]
    p = blocks["plant"]["transfer"]["expression"]
    entries = [(1, 1, "1"), (1, 3, "1"), (2, 2, "1"), (2, 1, f"-({c})"), (3, 3, "1"), (3, 2, f"-({p})")]
    condition["plant"] = {
        "format": "matrix",
        "signals": ["e", "u", "y"],
        "forcing_row": 1,
        "forcing": "1",
        "input_name": "r",
        "entries": [{"row": r, "col": k, "expression": x} for r, k, x in entries],
    }
    data["notes"] = (
        f"The compensator {c} on {p} in COEBRA's matrix format: row 1 e + y = r, row 2 u = C e, "
        "row 3 y = P u; the loop is broken at e."
    )
    return data


def table_session(
    table: dict, frequencies: list[float], compensator: str = "lead", algorithm: str | None = None
) -> dict:
    """A tabulated plant (a table transfer, e.g. from a CSV file beside the session) with a
    compensator; the grid spans the table's frequencies (in the table's unit)."""
    positive = sorted(f for f in frequencies if f > 0)
    if len(positive) < 2:
        raise SessionError("the table needs at least two positive frequencies")
    grid = {"unit": table["table"]["unit"], "start": positive[0], "stop": positive[-1], "points": 400, "spacing": "log"}
    return new_session(
        table,
        compensator,
        algorithm,
        grid=grid,
        notes=f"A tabulated plant ({table['table'].get('csv', 'inline')}) with a {compensator} "
        "compensator; targets PM >= 45 deg, GM >= 6 dB.",
    )


def dae_session() -> dict:
    """A copy of the bundled projection_integrator example, without its records."""
    data = json.loads((EXAMPLES / "projection_integrator.json").read_text(encoding="utf-8"))
    data.update(records=[], current_iteration=0, state=None)
    data.pop("sweeps", None)
    return data

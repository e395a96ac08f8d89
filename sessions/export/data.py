"""`loopcraft export --to json|csv`: a design as data.

json: per condition every entry (compensators first-class: numerator and
denominator coefficients in descending powers, zeros, poles and gain with
equal roots cancelled (the coefficients are not); for a
w-plane condition also the z-domain form by w = (z - 1)/(z + 1) with the
sample time), and the state-space matrices of the broken loop (SISO, input
the injected loop signal, output GH: 1 + GH = 0 closes it) and of the closed
loop (the network's inputs to every signal), from `engine.loop.realization`.
csv: the open loop GH and the closed loop T = GH/(1 + GH) at the break point
on the session's grid (frequency in the grid's unit).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import replace

import numpy as np

from engine.errors import EngineError
from engine.loop.design import closed_loop_realization, design
from engine.loop.responses import open_loop
from engine.model.bilinear import realization_in_z
from sessions.export.design_model import Design, ExportCondition, ExportEntry, not_finite, w_to_z
from sessions.store import Session


def design_json(d: Design, sample_time: float | None = None) -> dict:
    """The JSON data of a design (see the module doc); ``sample_time`` of w-plane z-domain forms."""
    return {
        "source": d.source,
        "iteration": d.iteration,
        "parameters": d.parameters,
        "conditions": [_condition(c, sample_time) for c in d.conditions],
    }


def _pairs(values) -> list[list[float]]:
    return [[float(complex(v).real), float(complex(v).imag)] for v in values]


def _entry(e: ExportEntry, variable: str, sample_time: float | None) -> dict:
    data = {
        "block": e.label,
        "input": e.input,
        "output": e.output,
        "kind": e.kind,
        "text": e.text,
        "compensator": e.compensator,
    }
    if e.kind == "delay":
        data["delay"] = e.delay
        return data
    if e.kind == "table":
        data.update(frequencies=list(e.omega), response=_pairs(e.response))
        return data
    if e.kind == "state_space":
        A, B, C, D = e.matrices
        data.update(A=[list(r) for r in A], B=list(B), C=list(C), D=D, zeros=_pairs(e.zeros), poles=_pairs(e.poles))
        data.update(gain=e.gain, sample_time=e.sample_time)
        return data
    data.update(
        numerator=list(e.num), denominator=list(e.den), zeros=_pairs(e.zeros), poles=_pairs(e.poles), gain=e.gain
    )
    if e.kind == "fitted":
        data.update(fit_residual=e.residual, fit_degree=e.degree)
    if variable == "w" and e.kind == "rational":
        numz, denz = w_to_z(e.num, e.den)
        data["z_domain"] = {
            "numerator": numz,
            "denominator": denz,
            "sample_time": sample_time,
            "map": "w = (z - 1)/(z + 1)",
        }
    return data


def _condition(c: ExportCondition, sample_time: float | None) -> dict:
    entries = [_entry(e, c.variable, sample_time) for e in c.entries]
    data = {
        "name": c.name,
        "variable": c.variable,
        "sample_time": c.sample_time,
        "break_at": c.break_at,
        "inputs": list(c.inputs),
        "signals": list(c.signals),
        "compensators": [e for e in entries if e["compensator"]],
        "entries": entries,
    }
    data.update(_state_spaces(c))
    return data


def _matrices(A, B, C, D) -> dict:
    return {
        "A": np.asarray(A).tolist(),
        "B": np.asarray(B).tolist(),
        "C": np.asarray(C).tolist(),
        "D": np.asarray(D).tolist(),
    }


def _state_spaces(c: ExportCondition) -> dict:
    """The broken loop's and the closed loop's A, B, C, D (None with the reason, for tables and delays)."""
    try:
        ss = design(c.network, c.values).loop(c.break_at).realization
        closed = closed_loop_realization(c.network, c.break_at, c.values)
    except (EngineError, ValueError, ArithmeticError) as exc:  # LinAlgError is a ValueError
        return {"open_loop": None, "closed_loop": None, "state_space_note": not_finite(exc)}
    k = c.network.signal(c.break_at)
    if c.sample_time is not None:  # realized in w: written in z
        ss = replace(ss, **dict(zip("ABCD", realization_in_z(ss.A, ss.B, ss.C, ss.D))))
        closed = replace(closed, **dict(zip("ABCD", realization_in_z(closed.A, closed.B, closed.C, closed.D))))
    loop = _matrices(ss.A, ss.B[:, -1:], -ss.C[k : k + 1], -ss.D[k : k + 1, -1:])
    loop.update(input=f"{c.break_at} (injected)", output="GH = -(returned " + c.break_at + ")")
    shut = _matrices(closed.A, closed.B, closed.C, closed.D)
    shut.update(inputs=list(closed.inputs), outputs=list(closed.outputs))
    return {"open_loop": loop, "closed_loop": shut}


CSV_HEADER = (
    "condition",
    "frequency",
    "open_mag_db",
    "open_phase_deg",
    "open_real",
    "open_imag",
    "closed_mag_db",
    "closed_phase_deg",
    "closed_real",
    "closed_imag",
)


def response_csv(session: Session, d: Design) -> str:
    """The open loop GH and T = GH/(1 + GH) at the break point, each condition on the session's grid."""
    grid = session.problem.grid
    scale = 2 * math.pi if grid.unit == "hz" else 1.0
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(CSV_HEADER[:1] + (f"frequency_{grid.unit.replace('/', '_per_')}",) + CSV_HEADER[2:])
    for c in d.conditions:
        try:
            gh = open_loop(c.network, c.break_at, grid.omega, c.values, sensitivities=False).value
        except EngineError as exc:
            raise EngineError(f"condition {c.name!r}: {exc}") from None
        with np.errstate(all="ignore"):
            t = gh / (1.0 + gh)
            columns = [_polar(gh), _polar(t)]
        for i, w in enumerate(grid.omega):
            writer.writerow([c.name, repr(float(w / scale))] + [repr(float(v[i])) for col in columns for v in col])
    return out.getvalue()


def _polar(h: np.ndarray) -> list[np.ndarray]:
    """Magnitude (dB), unwrapped phase (deg), real, imaginary."""
    finite = np.isfinite(h)
    phase = np.full(h.shape, np.nan)
    if finite.any():
        phase[finite] = np.degrees(np.unwrap(np.angle(h[finite])))
    return [20 * np.log10(np.abs(h)), phase, h.real, h.imag]

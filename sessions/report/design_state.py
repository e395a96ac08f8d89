"""The report's account of the design as it is (issue 40, section 1): where it comes
from (version, file, its hash, date), each requirement with its sense, unit, value
and how the value was obtained, the constraints and the bounds that bind, each
compensator as typed, in time-constant and in gain/zero/pole form, and for each flight
condition the loop's margins (each with its method), disk margin, Ms, Mt, delay
margin, closed-loop poles with their damping and natural frequency, and the step
measures.  Blocks as `sessions.report.content` describes them."""

from __future__ import annotations

import datetime
import hashlib
import math
from typing import Any

from engine.analysis import LoopAnalysis, analyze
from engine.closed_loop.delayed_step import digits_supported
from engine.closed_loop.step_response import RETURNS_TO_ZERO, network_step
from engine.design.compensator_items import compensators, pole_zero_form, time_constant_form
from engine.design.constraints import constraint_states
from engine.design.measure_kinds import MEASURE_KINDS
from engine.errors import EngineError
from engine.model.bilinear import z_transfer
from engine.model.blocks import ExpressionTransfer
from engine.stepping.presenter import number
from engine.stepping.protocol import MeasureRow, StepRecord
from sessions.new.templates import LOOPCRAFT_VERSION
from sessions.store import Session

Block = tuple
BINDS = 1e-6  # relative: a value this near a bound binds (constraints: `engine.design.constraints`)


def provenance(session: Session, k: int) -> list[Block]:
    """Where the design comes from: loopcraft's version, the session file and its SHA-256,
    the iteration, the date the report was made."""
    path = session.path
    digest = hashlib.sha256(path.read_bytes()).hexdigest() if path is not None and path.is_file() else "not saved"
    rows = [
        ["loopcraft", LOOPCRAFT_VERSION],
        ["session file", str(path.resolve()) if path is not None else "not saved"],
        ["SHA-256 of the file", digest],
        ["design", f"iteration {k} of {session.model.current_iteration}" + (" (the start)" if k == 0 else "")],
        ["algorithm", session.model.algorithm.name],
        ["report made", datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")],
    ]
    return [("table", ("", ""), rows)]


def requirement_rows(record: StepRecord | None, unit: str, methods: dict[str, str] | None = None) -> tuple[str, Block]:
    """The verdict line and the table of every measure of a design: what, where, the
    target with its sense, the value, met, at which frequency, how it was obtained
    (``methods``: each condition's margin method, for frequency measures that do not
    state their own)."""
    rows = list(record.measures) if record is not None else []
    judged = [r for r in rows if r.desired is not None]
    met = sum(bool(r.satisfied) for r in judged)
    verdict = f"{met} of {len(judged)} requirements met" if judged else "no requirement is set"
    table = [
        [
            _label(r),
            r.condition,
            _target(r),
            _value(r),
            "not judged" if r.desired is None else "met" if r.satisfied else "UNMET",
            "" if r.frequency is None else f"{number(r.frequency / (2 * math.pi if unit == 'hz' else 1.0))} {unit}",
            r.method or _method(r, (methods or {}).get(r.condition, "")),
        ]
        for r in rows
    ]
    return verdict, ("table", ("measure", "condition", "target", "value", "met", "at", "how obtained"), table)


def _label(row: MeasureRow) -> str:
    kind = MEASURE_KINDS.get(row.kind)
    return f"{row.name}: {kind.label}" if kind is not None else row.name


def _unit(row: MeasureRow) -> str:
    kind = MEASURE_KINDS.get(row.kind)
    return f" {kind.unit}" if kind is not None and kind.unit else ""


def _target(row: MeasureRow) -> str:
    if row.desired is None:
        return "(shown, not judged)"
    return f"{'>=' if row.at_least else '<='} {number(row.desired)}{_unit(row)}"


def _value(row: MeasureRow) -> str:
    return f"{number(row.value)}{_unit(row)}"


def _method(row: MeasureRow, margins: str) -> str:
    """How a value without a stated method was obtained, from its measure's domain (a
    frequency measure: the condition's margin method)."""
    kind = MEASURE_KINDS.get(row.kind)
    domain = kind.domain if kind is not None else ""
    return {"time": "simulated (exact discretization)", "poles": "closed-loop poles (eigenvalues)"}.get(domain, margins)


def constraints(session: Session, named: dict[str, Any]) -> list[Block]:
    """Every linear constraint as written, its slack at the design and whether it binds."""
    problem = session.problem
    if not problem.inequalities:
        return [("p", "No linear constraint.")]
    states = constraint_states(problem, problem.vector_from(named))
    rows = [[c.text or c.normal, c.normal, number(at.slack), at.state] for c, at in zip(problem.inequalities, states)]
    return [("table", ("constraint", "as A x <= b", "slack", "at the design"), rows)]


def parameters(session: Session, named: dict[str, Any]) -> list[Block]:
    """Each parameter: start, design value, bounds, free, and the bound it sits on."""
    rows = []
    for p in session.model.problem.parameters:
        final = named.get(p.name, p.value)
        free = "yes" if p.free else "held"
        rows.append(
            [p.name, number(p.value), number(final), number(p.min), number(p.max), free, _binds(final, p.min, p.max)]
        )
    return [("table", ("parameter", "start", "design", "min", "max", "free", "bound that binds"), rows)]


def _binds(value: Any, low: float | None, high: float | None) -> str:
    values = value if isinstance(value, (list, tuple)) else [value]
    found = []
    for v in values:
        if low is not None and math.isfinite(low) and abs(v - low) <= BINDS * max(1.0, abs(low)):
            found.append("min")
        elif high is not None and math.isfinite(high) and abs(v - high) <= BINDS * max(1.0, abs(high)):
            found.append("max")
    return ", ".join(dict.fromkeys(found))


def compensator_forms(session: Session, named: dict[str, Any]) -> list[Block]:
    """Each compensator block: as typed, in time-constant and in gain/zero/pole form at the
    design's values; once for the conditions where it reads the same, labelled with them
    when they differ (per-condition parameters)."""
    problem = session.problem
    if not problem.conditions:
        return [("p", "The session has no loop.")]
    seen: dict[tuple, list[str]] = {}
    for k, c in enumerate(problem.conditions):
        seen.setdefault(tuple(_forms(c.network, problem.condition_values(k, named=named))), []).append(c.name)
    rows = []
    for forms, names in seen.items():
        where = f" ({', '.join(names)})" if len(seen) > 1 else ""
        for label, typed, constants, zpk in forms:
            rows += [[label + where, "as typed", typed]]
            rows += [["", "time constants", constants]] if constants else []
            rows += [["", "gain, zeros, poles", zpk]]
    if not rows:
        return [("p", "No block has a parameter: the loop has no compensator to tune.")]
    return [("table", ("compensator", "form", "transfer function"), rows)]


def _forms(network, values: dict[str, float]) -> list[tuple[str, str, str, str]]:
    """(label, as typed, time-constant form, gain/zero/pole form) of each compensator; in a
    condition in z, as typed and in z (no time-constant form: its roots are z's)."""
    out = []
    for label, found in compensators(network, values).items():
        transfer: ExpressionTransfer = next(e for e in network.entries if e.label == label).transfer
        if network.sample_time is not None:
            typed = z_transfer(transfer)
            out.append((label, typed.text, "", pole_zero_form(typed, values)))
            continue
        variable = transfer.expression.variable
        out.append((label, transfer.text, time_constant_form(found, variable), pole_zero_form(transfer, values)))
    return out


def analyses(session: Session, named: dict[str, Any]) -> dict[str, LoopAnalysis | str]:
    """Each flight condition's loop analysis at the design (`engine.analysis.analyze`),
    or why it cannot be made."""
    problem = session.problem
    out: dict[str, LoopAnalysis | str] = {}
    for k, c in enumerate(problem.conditions):
        try:
            out[c.name] = analyze(c.network, c.break_at, problem.grid.omega, problem.condition_values(k, named=named))
        except EngineError as exc:
            out[c.name] = f"The loop cannot be analyzed: {exc}"
    return out


def loop_analysis(session: Session, named: dict[str, Any], found: dict[str, LoopAnalysis | str]) -> list[Block]:
    """For each flight condition: margins with their method, disk margin, Ms, Mt, delay
    margin, closed-loop poles (zeta, wn) and the step response's measures."""
    problem = session.problem
    blocks: list[Block] = []
    for k, c in enumerate(problem.conditions):
        blocks.append(("h3", f"Condition {c.name}"))
        result = found[c.name]
        if isinstance(result, str):
            blocks.append(("p", result))
            continue
        values = problem.condition_values(k, named=named)
        blocks += [_margins(result, problem.grid.unit), *_poles(result), *_step(c.network, values)]
        blocks += [("note", note) for note in result.notes]
    return blocks


def _margins(found: LoopAnalysis, unit: str) -> Block:
    scale = 2 * math.pi if unit == "hz" else 1.0
    how = found.margins.label
    rows = [["gain margin", f"{number(m.gain_db)} dB", number(m.frequency / scale), how] for m in found.margins.gain]
    rows += [
        ["phase margin", f"{number(m.phase_deg)} deg", number(m.frequency / scale), how] for m in found.margins.phase
    ]
    delay = found.delay_margin
    rows.append(["delay margin", "none needed (no crossover)" if delay is None else f"{number(delay)} s", "", how])
    if found.disk_margin is not None:
        d = found.disk_margin
        rows.append(["disk margin (skew 0)", f"alpha {number(d.alpha)}", number(d.frequency / scale), how])
    for name, peak in (("Ms = max |S|", found.sensitivity_peak), ("Mt = max |T|", found.complementary_peak)):
        if peak is not None:
            rows.append([name, number(peak.value), number(peak.frequency / scale), how])
    return ("table", ("measure", "value", f"at ({unit})", "how obtained"), rows)


def _poles(found: LoopAnalysis) -> list[Block]:
    if found.closed_loop_poles is None:
        return [("p", f"Closed loop: {found.verdict} (closed-loop poles need a rational loop).")]
    rows = []
    poles = found.closed_loop_poles
    for p, hidden in zip(poles, found.hidden or ("",) * len(poles)):
        z = complex(p.value)
        if z.imag < 0:
            continue
        text = f"{number(z.real)} +- {number(z.imag)}j" if z.imag > 0 else number(z.real)
        rows.append([text, number(p.damping), number(p.natural_frequency), f"fixed: {hidden}" if hidden else ""])
    return [
        (
            "p",
            f"Closed loop: {found.verdict}; its poles (eigenvalues of the closed loop's realization; a fixed mode "
            "is uncontrollable or unobservable from the loop, by the PBH test on the balanced realization):",
        ),
        ("table", ("pole", "zeta", "wn (rad/s)", "from the loop"), rows),
    ]


def _step(network, values: dict[str, float]) -> list[Block]:
    response = network_step(network, values)
    if response is None or response.measures is None:
        return []
    m = response.measures
    if abs(m.final) <= RETURNS_TO_ZERO * max(abs(v) for v in response.y):
        return [("p", f"Step response of {response.name}: it returns to 0 (a disturbance rejected): no step measures.")]
    errors = response.errors or {}

    def shown(x: float, name: str) -> str:  # a simulated measure to the digits its error estimate supports
        if name not in errors:
            return number(x)
        error = errors[name]
        text = f"{x:.{digits_supported(x, error)}g}"
        return text + (" (its two estimates disagree)" if not math.isfinite(error) else f" (+- {error:.1g})")

    def seconds(x: float | None, name: str) -> str:
        return "not reached in the horizon" if x is None else f"{shown(x, name)} s"

    rows = [
        ["final value", shown(m.final, "final")],
        ["rise time (10-90 %)", seconds(m.rise_time, "rise_time")],
        ["overshoot", f"{shown(m.overshoot_percent, 'overshoot_percent')} %"],
        ["peak time", seconds(m.peak_time, "peak_time")],
        ["settling time (5 %)", seconds(m.settling_time, "settling_time")],
    ]
    how = (
        "read on the samples, the output held between them: the peak is the largest sample, rise from the first "
        "sample at or above 10 % to the first at or above 90 %, settling the first sample after which every "
        "sample stays in the band"
        if network.sampled
        else f"{response.how}; each measure given to the digits its error estimate supports (+- that estimate)"
        if response.how
        else "simulated by exact discretization, each measure refined on the exact response: the crossings of "
        "10 %, 90 % and the band by root finding, the peak where the response's derivative vanishes"
    )
    blocks: list[Block] = [("p", f"Step response of {response.name} ({how}):"), ("table", ("", ""), rows)]
    return blocks + ([("p", f"Note: {response.note}.")] if response.note else [])

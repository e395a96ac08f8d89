"""The design report's content (`loopcraft report --format html|md`), as a list of
plain blocks that `sessions.report.render` writes as HTML or Markdown.

Blocks: ("h1"|"h2"|"h3", text), ("p", text), ("table", header, rows),
("figure", name, png bytes, caption), ("pre", text).  Content: the problem
(every condition's blocks, the compensators, the parameters with bounds, the
targets per condition, the algorithm), the initial and the final design with
their tableaux (met/unmet), the convergence history, the figures of every
condition (`sessions.report.figures`), and the algorithm's own report text
(its presenter's) as an appendix.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from engine.analysis import LoopCurve, loop_curve
from engine.closed_loop.time_response import Segment, simulate
from engine.design.notes import design_notes
from engine.errors import EngineError
from engine.loop.realization import realize
from engine.stepping.driver import first_record
from engine.stepping.presenter import tableau_text, tolerant
from engine.stepping.protocol import MeasureRow, StepRecord
from sessions.export.design_model import iteration_parameters
from sessions.lifecycle import registration, stepper
from sessions.report import figures
from sessions.store import Session

Block = tuple
DISTANCE = {
    "stability_margin": lambda v: v,
    "gain_margin": lambda v: v,
    "phase_margin": lambda v: v,
    "gain_margin_db": lambda db: 1 - 10 ** (-db / 20),
    "phase_margin_deg": lambda d: 2 * math.sin(math.radians(abs(d)) / 2),
}


def report_blocks(session: Session, iteration: int | None = None) -> list[Block]:
    """Every block of the report of ``session`` at ``iteration`` (default: its last)."""
    k, named = iteration_parameters(session, iteration)
    initial, final = _records(session, k)
    name = session.path.name if session.path else "session"
    blocks: list[Block] = [
        ("h1", f"Design report: {name}"),
        (
            "p",
            f"Algorithm {session.model.algorithm.name}; iteration {k} of "
            f"{session.model.current_iteration}. {session.model.notes}",
        ),
    ]
    blocks += _problem(session, named)
    blocks += _designs(initial, final, k)
    blocks += _convergence(session, k)
    blocks += _figures(session, named)
    blocks += _appendix(session, initial, final)
    return blocks


def _records(session: Session, k: int) -> tuple[StepRecord | None, StepRecord | None]:
    try:
        initial = first_record(registration(session).presenter, stepper(session))
    except EngineError:
        initial = None
    return initial, (session.records[k - 1] if k else initial)


def _number(x: Any) -> str:
    if x is None:
        return ""
    if isinstance(x, list):
        return " / ".join(_number(v) for v in x)
    if isinstance(x, float):
        return "-" if math.isnan(x) else f"{x:.6g}"
    return str(x)


def _problem(session: Session, named: dict | None) -> list[Block]:
    problem, model = session.problem, session.model.problem
    blocks: list[Block] = [("h2", "Problem")]
    for c in problem.conditions:
        rows = [
            [
                e.label,
                c.network.signals[e.col],
                c.network.signals[e.row],
                e.transfer.text,
                "compensator" if e.transfer.parameters else "plant",
            ]
            for e in c.network.entries
        ]
        blocks += [
            ("h3", f"Condition {c.name} (variable {c.network.variable}, loop broken at {c.break_at})"),
            ("table", ("block", "from", "to", "transfer", "role"), rows),
        ]
    final = problem.named() if named is None else named
    rows = [
        [
            p.name,
            _number(p.value),
            _number(p.min),
            _number(p.max),
            "yes" if p.free else "no",
            p.sign,
            _number(final.get(p.name)),
        ]
        for p in model.parameters
    ]
    blocks += [("h3", "Parameters"), ("table", ("name", "start", "min", "max", "free", "sign", "final"), rows)]
    rows = [
        [
            t.measure,
            t.condition or "all",
            "; ".join(_band(b) for b in t.bands),
            t.sense or "natural",
            _number(t.weight),
            "yes" if t.requirement else "objective only",
        ]
        for t in model.targets
    ]
    blocks += [("h3", "Targets"), ("table", ("measure", "condition", "bands", "sense", "weight", "requirement"), rows)]
    settings = ", ".join(f"{k}={v}" for k, v in session.model.algorithm.settings.items()) or "defaults"
    blocks.append(("p", f"Algorithm {session.model.algorithm.name} ({settings})."))
    return blocks


def _band(b) -> str:
    where = "" if b.low == 0 and b.high is None else f"{_number(b.low)}..{_number(b.high) or 'inf'}: "
    required = "" if b.required is None else f" (required {_number(b.required)})"
    return f"{where}{_number(b.desired)}{required}"


def _tableau(rows: list[MeasureRow]) -> Block:
    return (
        "table",
        ("name", "kind", "condition", "value", "frequency", "desired", "met"),
        [
            [
                r.name,
                r.kind,
                r.condition,
                _number(r.value),
                _number(r.frequency),
                _number(r.desired),
                "met" if r.satisfied else "UNMET",
            ]
            for r in rows
        ],
    )


def _designs(initial: StepRecord | None, final: StepRecord | None, k: int) -> list[Block]:
    blocks: list[Block] = [("h2", "Initial and final design")]
    for title, record in (("Initial design (iteration 0)", initial), (f"Final design (iteration {k})", final)):
        blocks.append(("h3", title))
        if record is None:
            blocks.append(("p", "The loop cannot be evaluated at this design."))
            continue
        met = sum(bool(r.satisfied) for r in record.measures)
        blocks += [
            (
                "p",
                f"{met} of {len(record.measures)} measures met. Parameters: "
                + ", ".join(f"{n} = {_number(v)}" for n, v in record.parameters.items()),
            ),
            _tableau(list(record.measures)),
        ]
    return blocks


def _convergence(session: Session, k: int) -> list[Block]:
    records = session.records[:k]
    blocks: list[Block] = [("h2", "Convergence history")]
    if not records:
        return blocks + [("p", "No iteration has run yet.")]
    presenter = registration(session).presenter
    label, points, rows = "", [], []
    for r in records:
        label, value = tolerant(lambda: presenter.convergence(r), lambda: (label, None))
        unmet = sum(not m.satisfied for m in r.measures)
        rows.append([str(r.iteration), r.status.value, _number(r.objective), _number(value), str(unmet)])
        if value is not None and math.isfinite(value):
            points.append((r.iteration, float(value)))
    blocks.append(("table", ("iteration", "status", "objective", label or "value", "unmet"), rows))
    if points:
        blocks.append(
            (
                "figure",
                "convergence",
                figures.convergence([p[0] for p in points], [p[1] for p in points], label),
                f"Convergence: {label}",
            )
        )
    return blocks


def _curve(session: Session, c: int, named: dict | None, label: str, role: str, marked: bool) -> LoopCurve | None:
    problem = session.problem
    condition = problem.conditions[c]
    values = problem.condition_values(c, named=named)
    try:
        return loop_curve(condition.network, condition.break_at, problem.grid.omega, values, label, role, c, marked)
    except EngineError:
        return None


def _circles(session: Session, name: str) -> list[tuple[str, float]]:
    """The margin targets of a condition as distances |1 + GH| around -1."""
    out = []
    for t in session.problem.targets:
        if t.condition not in (None, name) or t.measure not in DISTANCE or not t.bands or not t.at_least:
            continue
        radius = DISTANCE[t.measure](t.bands[0].desired)
        if 0 < radius < 4:
            out.append((f"{t.measure} {t.bands[0].desired:g}", radius))
    return out


def _figures(session: Session, named: dict | None) -> list[Block]:
    problem = session.problem
    blocks: list[Block] = [("h2", "Figures")]
    for c, condition in enumerate(problem.conditions):
        curves = [
            x
            for x in (
                _curve(session, c, None, "initial", "reference", named is None),
                _curve(session, c, named, "final", "current", True) if named is not None else None,
            )
            if x
        ]
        title = f"condition {condition.name}"
        blocks.append(("h3", f"Condition {condition.name}"))
        if not curves:
            blocks.append(("p", "The loop cannot be evaluated on the grid."))
            continue
        blocks += [
            (
                "figure",
                f"bode_{c}",
                figures.bode(curves, problem.grid.unit, f"Bode, {title}"),
                f"Bode, {title}: margins marked on the final design",
            ),
            (
                "figure",
                f"nyquist_{c}",
                figures.nyquist(curves, _circles(session, condition.name), f"Nyquist, {title}"),
                f"Nyquist, {title}: -1 and the margin targets as circles |1 + GH| around it",
            ),
            ("figure", f"nichols_{c}", figures.nichols(curves, f"Nichols, {title}"), f"Nichols, {title}"),
        ]
        traces = [
            t
            for t in (
                _step(session, c, None, "initial", "--"),
                _step(session, c, named, "final", "-") if named is not None else None,
            )
            if t
        ]
        if traces:
            blocks.append(
                (
                    "figure",
                    f"step_{c}",
                    figures.step([t[:4] for t in traces], traces[0][4], f"Step response, {title}"),
                    f"Closed-loop step response, {title}: {traces[0][4]}",
                )
            )
    return blocks


def _step(session: Session, c: int, named: dict | None, label: str, style: str):
    """Step at the first input, response of y (or c, x1, the last signal): rational loops only."""
    problem = session.problem
    network = problem.conditions[c].network
    if not network.rational:
        return None
    try:
        ss = realize(network, problem.condition_values(c, named=named))
        if not ss.inputs or ss.A.size == 0:
            return None
        output = next((n for n in ("y", "c", "x1") if n in ss.outputs), ss.outputs[-1])
        real = np.linalg.eigvals(ss.A).real
        slowest = np.abs(real[real < 0]).min(initial=np.inf)
        horizon = 5.0 / real.max() if real.max() > 0 else (min(8.0 / slowest, 1e4) if np.isfinite(slowest) else 10.0)
        t = np.linspace(0.0, horizon, 400)
        y = simulate(ss, ss.inputs[0], t, [Segment(0.0, step=1.0)])[:, ss.outputs.index(output)]
    except (EngineError, np.linalg.LinAlgError):
        return None
    return t, y, label, style, f"{output} (step at {ss.inputs[0]})"


def _appendix(session: Session, initial: StepRecord | None, final: StepRecord | None) -> list[Block]:
    presenter = registration(session).presenter
    blocks: list[Block] = [("h2", "Appendix: the algorithm's report")]
    for title, record in (("Iteration 0", initial), ("Final iteration", final)):
        if record is None or (title == "Final iteration" and record is initial):
            continue
        text = tolerant(lambda: presenter.report(record, session.problem), lambda: tableau_text(record.measures))
        notes = design_notes(session.problem, dict(record.parameters))  # as `loopcraft report` prints them
        text += "".join(f"\nnote: {n}" for n in notes)
        blocks += [("h3", f"{title} ({record.iteration})"), ("pre", text)]
    return blocks

"""The design report's content (`loopcraft report --format html|md`), as a list of
plain blocks that `sessions.report.render` writes as HTML or Markdown.

Blocks: ("h1"|"h2"|"h3", text), ("p", text), ("note", text), ("table", header,
rows), ("figure", name, png bytes, caption), ("pre", text).  Content: provenance,
the session's notes (as notes), the summary (every requirement with its sense, unit,
value and method), the compensators in three forms, the parameters and constraints
(which bind), the loop analysis of each condition (`sessions.report.design_state`), the
loop-at-a-time margins at every break and the multi-loop disk margin of a condition with
several breaks (`sessions.report.break_tables`),
the conditions' blocks and the targets as set, the initial and final tableaux, the
convergence history, the figures with the requirements drawn
(`sessions.report.figures`), the latest tolerance study's distributions when the
session keeps one, and the algorithm's own report text as an appendix.
"""

from __future__ import annotations

import math

import numpy as np

from engine.analysis import LoopCurve, loop_curve
from engine.closed_loop.step_response import network_step
from engine.design.measure_kinds import MEASURE_KINDS
from engine.design.notes import design_notes
from engine.errors import EngineError
from engine.model.bilinear import z_transfer
from engine.model.blocks import ExpressionTransfer
from engine.stepping.driver import first_record
from engine.stepping.presenter import number, tableau_text, tolerant
from engine.stepping.protocol import StepRecord
from sessions.export.design_model import iteration_parameters
from sessions.lifecycle import registration, stepper
from sessions.report import break_tables, design_state, figures
from sessions.store import Session
from sessions.sweeps.dispersion import PERCENTILE_KEYS

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
    design = session.problem.named() if named is None else named
    found = design_state.analyses(session, design)
    methods = {name: a.margins.label for name, a in found.items() if not isinstance(a, str)}
    verdict, requirements = design_state.requirement_rows(final, session.problem.grid.unit, methods)
    blocks: list[Block] = [("h1", f"Design report: {name}"), *design_state.provenance(session, k)]
    if session.model.notes.strip():
        blocks += [("h2", "Notes"), ("note", session.model.notes.strip())]
    blocks += [("h2", f"Summary: {verdict} (iteration {k})"), requirements]
    blocks += [("h2", "Compensator"), *design_state.compensator_forms(session, design)]
    blocks += [("h2", "Parameters"), *design_state.parameters(session, design)]
    blocks += [("h2", "Constraints"), *design_state.constraints(session, design)]
    blocks += [("h2", "Loop analysis at the design"), *design_state.loop_analysis(session, design, found)]
    blocks += break_tables.break_blocks(session, design)
    blocks += _problem(session)
    blocks += _designs(session, initial, final, k)
    blocks += _convergence(session, k)
    blocks += _figures(session, named, final)
    blocks += _tolerance_study(session)
    blocks += _appendix(session, initial, final)
    return blocks


def _records(session: Session, k: int) -> tuple[StepRecord | None, StepRecord | None]:
    try:
        initial = first_record(registration(session).presenter, stepper(session))
    except EngineError:
        initial = None
    return initial, (session.records[k - 1] if k else initial)


def _problem(session: Session) -> list[Block]:
    """The flight conditions (every block, its signals and role) and the targets as set."""
    problem, model = session.problem, session.model.problem
    blocks: list[Block] = [("h2", "Flight conditions and targets")]
    for k, c in enumerate(problem.conditions):
        junctions = _junctions(model.conditions[k]) if k < len(model.conditions) else set()
        rows = [
            [e.label, c.network.signals[e.col], c.network.signals[e.row], _typed(c.network, e), _role(e, junctions)]
            for e in c.network.entries
        ]
        T = c.network.sample_time
        plane = f"in z, every {T:g} s" if T is not None else f"variable {c.network.variable}"
        blocks += [
            ("h3", f"Condition {c.name} ({plane}, loop broken at {c.break_at})"),
            ("table", ("block", "from", "to", "transfer", "role"), rows),
        ]
    rows = [
        [
            t.measure,
            t.condition or "all",
            _sense(t.measure, t.sense),
            "; ".join(_band(b) for b in t.bands),
            number(t.weight),
            "yes" if t.requirement else "objective only",
        ]
        for t in model.targets
    ]
    blocks += [("h3", "Targets"), ("table", ("measure", "condition", "sense", "bands", "weight", "requirement"), rows)]
    settings = ", ".join(f"{k}={v}" for k, v in session.model.algorithm.settings.items()) or "defaults"
    blocks.append(("p", f"Algorithm {session.model.algorithm.name} ({settings})."))
    return blocks


def _junctions(condition) -> set[str]:
    plant = condition.plant
    return {j.name for j in getattr(plant, "junctions", None) or ()}


def _typed(network, entry) -> str:
    """An entry's transfer as typed (a condition in z's in z, not its w-plane form)."""
    if network.sample_time is not None and isinstance(entry.transfer, ExpressionTransfer):
        return z_transfer(entry.transfer).text
    return entry.transfer.text


def _role(entry, junctions: set[str]) -> str:
    if entry.transfer.parameters:
        return "compensator"
    if entry.label in junctions:
        return f"summing junction ({'+' if entry.transfer.text.lstrip()[:1] != '-' else '-'})"
    return "plant"


def _sense(measure: str, sense: str | None) -> str:
    """'>= (at least)' or '<= (at most)' with the measure's unit."""
    kind = MEASURE_KINDS.get(measure)
    at_least = sense == "at_least" if sense is not None else (kind.at_least if kind is not None else True)
    unit = f", {kind.unit}" if kind is not None and kind.unit else ""
    return (">= (at least" if at_least else "<= (at most") + unit + ")"


def _band(b) -> str:
    where = "" if b.low == 0 and b.high is None else f"{number(b.low)}..{number(b.high) or 'inf'}: "
    required = "" if b.required is None else f" (required {number(b.required)})"
    return f"{where}{number(b.desired)}{required}"


def _designs(session: Session, initial: StepRecord | None, final: StepRecord | None, k: int) -> list[Block]:
    """The initial and final tableaux, each margin's "how obtained" from its own design's analysis."""
    blocks: list[Block] = [("h2", "Initial and final design")]
    for title, record in (("Initial design (iteration 0)", initial), (f"Final design (iteration {k})", final)):
        blocks.append(("h3", title))
        if record is None:
            blocks.append(("p", "The loop cannot be evaluated at this design."))
            continue
        found = design_state.analyses(session, dict(record.parameters))
        methods = {name: a.margins.label for name, a in found.items() if not isinstance(a, str)}
        verdict, table = design_state.requirement_rows(record, session.problem.grid.unit, methods)
        values = ", ".join(f"{n} = {number(v)}" for n, v in record.parameters.items())
        blocks += [("p", f"{verdict}. Parameters: {values}"), table]
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
        rows.append([str(r.iteration), r.status.value, number(r.objective), number(value), str(unmet)])
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


def _figures(session: Session, named: dict | None, final: StepRecord | None) -> list[Block]:
    """Per condition: Bode, Nyquist, Nichols, S/T, the root locus (rational loops) and the
    step response, the requirements drawn on them as the workbench draws them."""
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
        rows = [r for r in (final.measures if final is not None else ()) if r.condition == condition.name]
        targets = [t for t in problem.targets if t.condition in (None, condition.name)]
        blocks.append(("h3", f"Condition {condition.name}"))
        if not curves:
            blocks.append(("p", "The loop cannot be evaluated on the grid."))
            continue
        unit = problem.grid.unit
        blocks += [
            (
                "figure",
                f"bode_{c}",
                figures.bode(curves, unit, f"Bode, {title}", rows, targets),
                f"Bode, {title}: margins and targets",
            ),
            (
                "figure",
                f"nyquist_{c}",
                figures.nyquist(curves, _circles(session, condition.name), f"Nyquist, {title}"),
                f"Nyquist, {title}: -1 and the margin targets as circles |1 + GH| around it",
            ),
            (
                "figure",
                f"nichols_{c}",
                figures.nichols(curves, f"Nichols, {title}", rows),
                f"Nichols, {title}: the margins' requirements on the curve's branch",
            ),
            (
                "figure",
                f"st_{c}",
                figures.sensitivity(curves, unit, f"S and T, {title}", rows),
                f"|S| and |T|, {title}",
            ),
        ]
        blocks += _locus(session, c, named, title) + _step_figure(session, c, named, title, rows)
    return blocks


def _locus(session: Session, c: int, named: dict | None, title: str) -> list[Block]:
    """The root locus in the loop gain at the design (rational loops)."""
    from engine.closed_loop.root_locus import pole_zero_map, root_locus

    condition = session.problem.conditions[c]
    if not condition.network.rational:
        return []
    values = session.problem.condition_values(c, named=named)
    try:
        found = root_locus(condition.network, condition.break_at, values, polished=False)
        pz = pole_zero_map(condition.network, condition.break_at, values)
    except EngineError:
        return []
    chart = figures.locus(found, pz, f"Root locus, {title}", condition.network.sample_time)
    return [("figure", f"locus_{c}", chart, f"Root locus in the loop gain, {title}")]


def _step_figure(session: Session, c: int, named: dict | None, title: str, rows) -> list[Block]:
    traces = [t for t in (_step(session, c, None, "initial", "--"), _step(session, c, named, "final", "-")) if t]
    if named is None:
        traces = traces[:1]
    if not traces:
        return []
    what = traces[0][4]
    chart = figures.step([t[:4] for t in traces], what, f"Step response, {title}", rows, traces[-1][5])
    how = f" ({traces[-1][6]})" if traces[-1][6] else ""
    return [("figure", f"step_{c}", chart, f"Closed-loop step response, {title}: {what}{how}")]


def _step(session: Session, c: int, named: dict | None, label: str, style: str):
    """The step response of the default output to the first input (rational loops, and continuous loops
    with delays, simulated): t, y, label, style, what it is, its measures, how it was obtained (None:
    exactly)."""
    problem = session.problem
    response = network_step(problem.conditions[c].network, problem.condition_values(c, named=named))
    if response is None:
        return None
    return np.array(response.t), np.array(response.y), label, style, response.name, response.measures, response.how


def _tolerance_study(session: Session) -> list[Block]:
    """The latest tolerance study kept in the session, when there is one: per measure and
    flight condition its percentiles, the fraction unmet with its 95 % Clopper-Pearson
    interval, the worst sample with its drawn values, and the histograms."""
    studies = [sweep for sweep in session.model.sweeps if sweep.kind == "tolerance"]
    if not studies:
        return []
    study, settings = studies[-1], studies[-1].settings
    laws = ", ".join(settings.get("tolerance", []))
    blocks: list[Block] = [
        ("h2", "Tolerance study"),
        (
            "p",
            f"{settings.get('samples', len(study.runs))} samples of {laws}, "
            f"drawn {settings.get('sampling', 'random')} with seed "
            f"{settings.get('seed')}, at the design of {study.created} ({len(study.failed)} failed).",
        ),
    ]
    rows = [row for row in study.worst_case if row.get("histogram") is not None]
    if not rows:
        return blocks + [("p", "The study kept no distribution (it was saved before they were): run it again.")]
    header = ("measure", "condition", *PERCENTILE_KEYS, "unmet % [95 %]", "worst sample")
    table = [
        [
            row["name"],
            row["condition"],
            *(number(_float(row["percentiles"].get(key))) for key in PERCENTILE_KEYS),
            "{:.1f} [{:.1f}, {:.1f}]".format(*(100 * v for v in (row["unmet_fraction"], *row["unmet_interval"]))),
            f"{row['worst_sample']}: " + ", ".join(f"{k} = {number(v)}" for k, v in row["worst_parameters"].items()),
        ]
        for row in rows
    ]
    caption = "Histograms of the samples' values; the desired value green when every sample meets it, else red"
    return blocks + [("table", header, table), ("figure", "tolerance", figures.histograms(rows), caption)]


def _float(value) -> float | None:
    """A number kept in the session's JSON (infinities and NaN as text) as a float."""
    return None if value is None else float(value)


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

"""COEBRA's performance measures (report 003, sections 1.3 and 2.2, Appendix C):
one row per target, band and flight condition, evaluated on the true responses.

Frequency measures come from the exact margins of `engine.margins.search`; in each
band the worst candidate is the row's value (the smallest gain or phase
margin, the largest modal peak), except the crossover frequency, which is
the highest gain crossover in the band (the rigid-body crossover when the
band stops below the bending modes).  Time measures come from the closed-loop
state space (`engine.loop.realization`) under a profile of steps and ramps, or,
for a mean square, from a Lyapunov equation (Appendix C: the mean square is
(1/2 pi) times the integral of |H|^2 times the input's PSD, here |F(jw)|^2
for a shaping filter F, i.e. the squared H2 norm of H F).  Step measures read
the response against the closed loop's DC gain times the final input when the
loop is stable (y at the horizon otherwise, `engine.closed_loop.time_response.final_value`);
overshoot and peak time are report 003's, the first half cycle's
(``peak_rule="first_half_cycle"``, not the global maximum).

A row whose measure does not occur (no phase crossover in a gain-margin
band, a mode whose peak left its band) is *absent*: its value is NaN and it
counts as met, except rise and settling times that never happen (+inf).  A time row of
a condition whose closed loop is unstable is undefined (NaN: never met, earning nothing),
whatever the response showed on its horizon.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.time_response import PeakRule, Segment, final_value, simulate, step_measures
from engine.design.measure_kinds import EVERY_BREAK, MEASURE_KINDS, TargetUse, absence, absent_reason, kind, met, names
from engine.design.problem import FREQUENCY_MEASURES, Condition, Problem, TimeResponse
from engine.design.tableau import stability_abscissa
from engine.errors import EngineError
from engine.loop.design import closed_loop_realization
from engine.loop.realization import StateSpace, cascade, poles, stability
from engine.loop.responses import LoopModel, loop_model
from engine.margins.batch import BatchLoops
from engine.margins.search import Margins, margins
from engine.margins.values import margin_forms
from engine.model.blocks import ExpressionTransfer
from engine.multiloop.network_breaks import diagram_disk_margin
from engine.slp.peaks import closed_loop_values

SLP_PEAK_RULE: PeakRule = "first_half_cycle"  # report 003's overshoot: the first half cycle above final
# the measures read from the attenuation minima (`engine.design.measure_kinds`: margin family A)
PEAK_KINDS = tuple(name for name, k in MEASURE_KINDS.items() if k.margin == "A")
MARGIN_ATTRIBUTE = {
    "gain_margin": ("gain", "value"),
    "phase_margin": ("phase", "value"),
    "stability_margin": ("stability", "value"),
    "attenuation_margin": ("attenuation", "value"),
    "gain_margin_db": ("gain", "gain_db"),
    "phase_margin_deg": ("phase", "phase_deg"),
}
# a row's name: the measure's tag (COEBRA's listing: GM, PM, WC, ...) and its count in the condition
SHORT = {name: k.tag for name, k in MEASURE_KINDS.items()}
TARGETS = TargetUse(measures=names(), refusal="is not an slp measure", breaks=True)  # every measure, any break


@dataclass(frozen=True)
class Spec:
    """One performance measure of one flight condition (a row of COEBRA's list).

    ``required`` is SPEC(i), the least acceptable value (None: the row is
    only in the objective); ``desired`` caps the figure of merit.  Values are
    as the user reads them; ``at_least`` says which way is better.
    """

    name: str
    kind: str
    condition: int
    target: int | None
    low: float
    high: float
    at_least: bool
    required: float | None
    desired: float | None
    weight: float = 1.0
    scale: float = 1.0
    at: str = ""  # the loop break a frequency measure is read at ("": the condition's break_at)

    @property
    def sign(self) -> float:
        """+1 for at-least rows, -1 for at-most rows: sign * value is 'larger is better'."""
        return 1.0 if self.at_least else -1.0

    def met(self, value: float) -> bool:
        """Whether a value satisfies the requirement (`engine.design.measure_kinds.met`: an
        objective-only row is met, a NaN never is; an absent feature stands at its absence
        value, `frequency_value`)."""
        if self.kind == "stability_abscissa" and self.required is not None and not math.isnan(value):
            return value > self.required
        return met(value, self.required, self.at_least)


def measure_specs(problem: Problem, require_stable: bool = True) -> tuple[Spec, ...]:
    """Every row: each target in each condition it applies to (one per band),
    plus a closed-loop stability row per rational condition if asked."""
    TARGETS.check_targets("slp", problem.targets)
    specs: list[Spec] = []
    for c, condition in enumerate(problem.conditions):
        counts: dict[tuple[str, str], int] = {}
        for k, target in enumerate(problem.targets):
            if target.condition not in (None, condition.name):
                continue
            at = target.break_in(condition)
            suffix = "" if at == condition.break_at else f"@{at}"  # a row at another break names it
            needs_time = kind(target.measure).domain in ("time", "poles")
            if needs_time and not condition.network.rational:
                raise EngineError(
                    f"target {k} ({target.measure}): condition {condition.name!r} is not rational "
                    "(tables or delays): no time response"
                )
            if target.measure in EVERY_BREAK and not condition.network.rational:
                raise EngineError(
                    f"target {k} ({target.measure}): condition {condition.name!r} is not rational "
                    "(tables or delays): its breaks have no loop matrix"
                )
            for band in target.bands or ():
                counts[target.measure, at] = counts.get((target.measure, at), 0) + 1
                specs.append(
                    Spec(
                        f"{SHORT[target.measure]}{counts[target.measure, at]}{suffix}",
                        target.measure,
                        c,
                        k,
                        band.low,
                        band.high,
                        target.at_least,
                        band.requirement if target.requirement else None,
                        band.desired,
                        target.weight,
                        target.scale,
                        at,
                    )
                )
        has_stability = any(s.kind == "stability_abscissa" and s.condition == c for s in specs)
        if require_stable and condition.network.rational and not has_stability:
            specs.append(
                Spec(
                    SHORT["stability_abscissa"],
                    "stability_abscissa",
                    c,
                    None,
                    0.0,
                    math.inf,
                    kind("stability_abscissa").at_least,
                    0.0,
                    None,
                    0.0,
                )
            )
    return tuple(specs)


def evaluate(
    problem: Problem, x: Sequence[float], specs: Sequence[Spec], conditions: Sequence[int] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(values, frequencies) of the rows, NaN where absent or not evaluated
    (only the rows of ``conditions`` when given)."""
    values = np.full(len(specs), np.nan)
    frequencies = np.full(len(specs), np.nan)
    wanted = range(len(problem.conditions)) if conditions is None else conditions
    for c in wanted:
        rows = [i for i, s in enumerate(specs) if s.condition == c]
        if rows:
            v, f = condition_values(problem, x, c, [specs[i] for i in rows])
            values[rows], frequencies[rows] = v, f
    return values, frequencies


def condition_values(
    problem: Problem, x: Sequence[float], c: int, specs: Sequence[Spec]
) -> tuple[list[float], list[float]]:
    """Values and frequencies of one condition's rows at the free values ``x``."""
    condition = problem.conditions[c]
    params = problem.condition_values(c, x)
    ss = None
    if any(s.kind not in FREQUENCY_MEASURES for s in specs):
        ss = closed_loop_realization(condition.network, condition.break_at, params)
    values, frequencies = [math.nan] * len(specs), [math.nan] * len(specs)
    for at, rows in rows_by_break(condition, specs).items():
        mine = [specs[i] for i in rows]
        model = loop_model(condition.network, at, problem.grid.omega, params)
        found = margins(model, attenuation_above=0.0 if any(s.kind in PEAK_KINDS for s in mine) else None)
        closed = closed_loop_values(condition, params, model, found, mine, ss)
        for k, (i, s) in enumerate(zip(rows, mine)):
            values[i], frequencies[i] = closed[k] if k in closed else frequency_value(s, found, model)
    for i, s in enumerate(specs):
        if s.kind not in FREQUENCY_MEASURES:
            values[i] = time_value(s, problem, ss, condition.network.sample_time)
    every = [i for i, s in enumerate(specs) if s.kind in EVERY_BREAK]
    if every:
        together = diagram_disk_margin(condition.network, condition.every_break, params)
        for i in every:
            values[i], frequencies[i] = together.alpha, together.frequency
    return values, frequencies


def spec_break(spec: Spec, condition: Condition) -> str:
    """The signal where a row's loop is broken: its target's break, else the condition's."""
    return spec.at or condition.break_at


def rows_by_break(
    condition: Condition, specs: Sequence[Spec], rows: Sequence[int] | None = None
) -> dict[str, list[int]]:
    """The frequency rows among ``rows`` (default: all) of one condition read on one loop, by the break
    their loop is read at (a row read at every break at once, `EVERY_BREAK`, is on none)."""
    out: dict[str, list[int]] = {}
    for i in range(len(specs)) if rows is None else rows:
        if specs[i].kind in FREQUENCY_MEASURES and specs[i].kind not in EVERY_BREAK:
            out.setdefault(spec_break(specs[i], condition), []).append(i)
    return out


def frequency_value(spec: Spec, found: Margins, model: LoopModel) -> tuple[float, float]:
    """The row's value and the frequency it was found at; a feature the loop lacks stands at
    its absence value (`engine.design.measure_kinds.absence`) at frequency NaN."""
    inside = lambda ms: [m for m in ms if spec.low <= m.frequency <= spec.high]  # noqa: E731
    if spec.kind == "crossover_frequency":
        cross = inside(found.phase)
        if cross:
            return (max(m.frequency for m in cross),) * 2
        band = (model.omega >= spec.low) & (model.omega <= spec.high)
        return _absent(spec, np.abs(model.gh[band]))
    if spec.kind in ("modal_peak_db", "modal_peak_phase_deg"):
        peaks = inside(found.attenuation)
        if not peaks:
            return _absent(spec)
        top = max(peaks, key=lambda m: abs(m.gh))
        if spec.kind == "modal_peak_db":
            return 20.0 * math.log10(abs(top.gh)), top.frequency
        return abs(math.degrees(np.angle(top.gh))), top.frequency
    family, attribute = MARGIN_ATTRIBUTE[spec.kind]
    candidates = inside(getattr(found, family))
    if not candidates:
        return _absent(spec)
    pick = min if spec.at_least else max
    worst = pick(candidates, key=lambda m: float(getattr(m, attribute)))
    return float(getattr(worst, attribute)), worst.frequency


def frequency_values(spec: Spec, loops: BatchLoops) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
    """`frequency_value` of a margin, modal peak or crossover row for every sample of a batch
    (`engine.margins.batch.BatchLoops`), without a `Margin` per sample: the values, the
    frequencies, and the samples whose row the batch cannot give (a crossover absent from the
    band: its absence value reads the grid response)."""
    modal = spec.kind in ("modal_peak_db", "modal_peak_phase_deg")
    family = (
        "phase" if spec.kind == "crossover_frequency" else "attenuation" if modal else MARGIN_ATTRIBUTE[spec.kind][0]
    )
    w, gh = {"gain": (loops.gain, loops.gain_gh), "phase": (loops.phase, loops.phase_gh)}.get(
        family, (loops.peaks, loops.peaks_gh)
    )
    empty = np.full((w.shape[0], 1), np.nan)
    w, gh = np.concatenate([w, empty], axis=1), np.concatenate([gh, empty + 0j], axis=1)  # a column at least
    with np.errstate(invalid="ignore"):
        inside = (w >= spec.low) & (w <= spec.high)
    some = inside.any(axis=1)
    if spec.kind == "crossover_frequency":
        top = np.max(np.where(inside, w, -np.inf), axis=1)
        return top, top, ~some
    key = np.abs(gh) if modal else margin_forms(family[0].upper(), w, gh)[MARGIN_ATTRIBUTE[spec.kind][1]]
    if spec.at_least and not modal:
        pick = np.argmin(np.where(inside, key, np.inf), axis=1)
    else:
        pick = np.argmax(np.where(inside, key, -np.inf), axis=1)
    # every candidate at the sentinel (an infinite margin): the first candidate, as min() and max() take it
    pick = np.where(np.take_along_axis(inside, pick[:, None], 1)[:, 0], pick, np.argmax(inside, axis=1))
    value, frequency, top = (np.take_along_axis(a, pick[:, None], 1)[:, 0] for a in (key, w, gh))
    if modal:
        with np.errstate(divide="ignore"):
            value = 20.0 * np.log10(np.abs(top)) if spec.kind == "modal_peak_db" else np.abs(np.degrees(np.angle(top)))
    return np.where(some, value, _absent(spec)[0]), np.where(some, frequency, np.nan), np.zeros(w.shape[0], dtype=bool)


def _absent(spec: Spec, magnitudes: NDArray | None = None) -> tuple[float, float]:
    found = absence(spec.kind, magnitudes)
    return (math.nan if found is None else found[0]), math.nan


def absent_row(spec: Spec, value: float, frequency: float) -> bool:
    """Whether a row stands at its absence value (a feature the loop lacks): such a row has
    no partials and no place in the linear program (it is judged, not steered)."""
    return spec.kind in FREQUENCY_MEASURES and math.isnan(frequency) and absent_reason(spec.kind, value) is not None


def time_value(spec: Spec, problem: Problem, ss: StateSpace, sample_time: float | None = None) -> float:
    """A time-domain row's value, or the closed-loop stability abscissa (of a sampled loop's
    s-plane equivalent, ``sample_time`` given: its realization is in w)."""
    if spec.kind == "stability_abscissa":
        return stability_abscissa(ss, sample_time)
    response = problem.targets[spec.target].response
    if spec.kind == "mean_square":
        return math.nan if grows(ss) else mean_square(ss, response.input, response.output, response.psd)
    if response.input not in ss.inputs:
        raise EngineError(
            f"target {spec.target}: {response.input!r} is not an input of condition "
            f"{problem.conditions[spec.condition].name!r} (inputs: {', '.join(ss.inputs)})"
        )
    if response.output not in ss.outputs:
        raise EngineError(f"target {spec.target}: unknown output signal {response.output!r}")
    t = response_times(response, ss.sample_time)
    segments = [Segment(*p) for p in response.profile]
    y = simulate(ss, response.input, t, segments)[:, ss.outputs.index(response.output)]
    return response_value(spec, response, ss, t, y)


def grows(ss: StateSpace) -> bool:
    """Whether the closed loop ``ss`` is unstable (a sampled loop's realization is in w: the same half-plane)."""
    return stability(poles(ss)) == "unstable"


def response_times(response: TimeResponse, sample_time: float | None) -> NDArray[np.float64]:
    """The times a response row is read at: its grid, or a sampled loop's samples up to its horizon."""
    if sample_time is None:
        return np.linspace(0.0, response.horizon, response.points)
    return np.arange(math.floor(response.horizon / sample_time + 1e-9) + 1) * sample_time


def response_value(
    spec: Spec, response: TimeResponse, ss: StateSpace, t: NDArray, y: NDArray, unstable: bool | None = None
) -> float:
    """A time row's value from its output's response ``y`` at ``t`` (the closed loop ``ss``'s
    response to the target's profile); ``unstable``: `grows(ss)` when already known."""
    if grows(ss) if unstable is None else unstable:
        return math.nan  # an unstable loop's response grows without bound: what the horizon shows means nothing
    if spec.kind == "peak_response":
        return float(np.max(np.abs(y)))
    segments = [Segment(*p) for p in response.profile]
    final, source = final_value(ss, response.input, response.output, segments, y)
    if spec.kind == "steady_state_error":
        return abs(response.reference - final)
    if final == 0 or not math.isfinite(final):
        return math.inf if spec.kind in ("rise_time", "settling_time") else math.nan
    m = step_measures(
        t,
        y,
        final,
        response.reference,
        response.settling_band,
        final_from=source,
        peak_rule=SLP_PEAK_RULE,
        held=ss.sample_time is not None,
    )
    value = {
        "rise_time": m.rise_time,
        "settling_time": m.settling_time,
        "peak_time": m.peak_time,
        "overshoot_percent": m.overshoot_percent,
    }[spec.kind]
    if value is None:
        return math.inf if spec.kind in ("rise_time", "settling_time") else math.nan
    return float(value)


def mean_square(ss: StateSpace, input_name: str, output: str, psd: str | None) -> float:
    """E[y^2] for white noise through the shaping filter F (PSD |F(jw)|^2, two-sided,
    (1/2 pi) integral over all w) into ``input_name``: C P C' with A P + P A' + B B' = 0."""
    if psd is None:
        raise EngineError("a mean square needs the input's PSD as a shaping filter F(s) (response.psd)")
    k, j = ss.inputs.index(input_name), ss.outputs.index(output)
    rational = ExpressionTransfer(psd).rational({})
    af, bf, cf, df = cascade(rational.num, rational.den)
    n, nf = ss.A.shape[0], af.shape[0]
    A = np.block([[ss.A, np.outer(ss.B[:, k], cf[0])], [np.zeros((nf, n)), af]])
    B = np.concatenate([ss.B[:, k] * df[0, 0], bf[:, 0]])
    C = np.concatenate([ss.C[j], ss.D[j, k] * cf[0]])
    D = ss.D[j, k] * df[0, 0]
    if D != 0:
        return math.inf  # white noise straight to the output
    if A.size and np.max(np.linalg.eigvals(A).real) >= 0:
        return math.inf
    from scipy.linalg import solve_continuous_lyapunov  # on first use (start-up)

    P = solve_continuous_lyapunov(A, -np.outer(B, B))
    return float(C @ P @ C)

"""CIP's requirements: the margins of every condition's loop, each with its
desired value, written as report 000 does (chapter VI, listing MAIN).

Order and numbering follow the listing's tableau: relative stability first
(gain margins, phase margins, gain/phase margins copied as stability margins
when asked (INCGMS/INCPMS), then the stability margins), attenuation margins
last.  A stability minimum found at the frequency of a copied gain or phase
margin is dropped, as the listing keeps only the first of equal points.

Reading of the listing where it is ambiguous: a copied margin takes the
*stability* target's desired value and push point (Table 1 of the report
shows the copy of the 0.88436 gain margin with desired 0.505, whereas the
listing's loop 220 would keep the gain-margin radius).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from engine.design.measure_kinds import TargetUse, kind
from engine.design.problem import Point, Problem, Target
from engine.errors import EngineError
from engine.loop.responses import LoopModel, loop_model, open_loop
from engine.margins.search import Margin, margins

# measure -> margin kind (G, P, S, A) of the measures cip accepts (`engine.design.measure_kinds`)
# the measures cip's targets may name: distances at one frequency (and their classical forms)
TARGETS = TargetUse(
    measures=(
        "gain_margin",
        "phase_margin",
        "stability_margin",
        "attenuation_margin",
        "gain_margin_db",
        "phase_margin_deg",
        "disk_margin",
        "sensitivity_peak",
        "complementary_sensitivity_peak",
    ),
    refusal="is not a margin (cip improves gain, phase, stability, attenuation and disk margins, Ms and Mt)",
    breaks=True,  # a target may name a loop break: its margins are read on the loop broken there
    refusals=(
        (
            "delay_margin",
            "is not a distance cip can push at one frequency (a delay margin is the phase margin over a "
            "crossover frequency that moves with the design); use slp",
        ),
    ),
)
KIND = {name: kind(name).margin for name in TARGETS.measures}
DEFAULT_POINTS = {
    "G": (Point(-1.0, "push"),),
    "P": (Point(-1.0, "push"),),
    "S": (Point(-1.0, "push"),),
    "A": (Point(0.0, "pull"),),
    "D": (),
}  # D: each its own point (peaks.py)


@dataclass(frozen=True)
class Requirement:
    """One margin with its requirement.

    ``value``/``desired`` are distances (report 000's units: from -1 for G, P
    and S, from the origin for A); ``shown``/``shown_desired`` are in the
    target's own units (dB and degrees for the classical forms).
    ``family`` identifies the target (and copy) it belongs to, for matching
    margins from one iteration to the next.
    """

    family: str
    kind: str
    measure: str
    condition: int
    frequency: float
    value: float
    desired: float
    shown: float
    shown_desired: float
    weight: float
    points: tuple[Point, ...]
    gh: complex
    method: str = "grid"  # how the margin was detected (`Margins.label`)
    loop_break: str = ""  # the loop break it is read at ('': the condition's break_at)

    @property
    def at_least(self) -> bool:
        """The distance's sense: at most for an attenuation margin, at least for every
        other (1/Ms, 1/Mt and the disk margin's |1 + F| included)."""
        return self.kind != "A"

    @property
    def shown_at_least(self) -> bool:
        """The sense of ``shown``, the measure's own (at most for Ms and Mt)."""
        return kind(self.measure).at_least

    @property
    def active(self) -> bool:
        """Unsatisfied (the report's active requirement)."""
        return self.value < self.desired if self.at_least else self.value > self.desired

    @property
    def goodness(self) -> float:
        """The value in >= form: larger is better."""
        return self.value if self.at_least else -self.value

    def to_json(self) -> dict:
        data = {
            k: getattr(self, k)
            for k in (
                "family",
                "kind",
                "measure",
                "condition",
                "frequency",
                "value",
                "desired",
                "shown",
                "shown_desired",
                "weight",
                "method",
            )
        }
        data["points"] = [[p.value.real, p.value.imag, p.mode] for p in self.points]
        data["gh"] = [self.gh.real, self.gh.imag]
        if self.loop_break:  # written only at another break: earlier records read back as they were
            data["loop_break"] = self.loop_break
        return data

    @staticmethod
    def from_json(data: dict) -> Requirement:
        points = tuple(Point(complex(re, im), mode) for re, im, mode in data["points"])
        rest = {k: v for k, v in data.items() if k not in ("points", "gh")}
        return Requirement(**rest, points=points, gh=complex(*data["gh"]))


def check_targets(problem: Problem) -> None:
    """CIP works on the four margin kinds (and their classical forms) only."""
    TARGETS.check_targets("cip", problem.targets)
    if not problem.targets:
        raise EngineError("cip: the problem has no targets to improve")
    from engine.cip.peaks import check_peak_targets  # peaks.py builds on this module's Requirement

    check_peak_targets(problem.targets)


def detect(
    problem: Problem, x: NDArray, detection: str, gain_as_stability: bool = False, phase_as_stability: bool = False
) -> tuple[list[Requirement], list[float]]:
    """Every requirement at the free vector ``x``, in tableau order, and the
    winding of 1 + GH along the grid per condition (turns; a stability guard).

    ``detection``: ``grid`` (report 000's grid rules on the user's grid),
    ``refined`` (exact loops refined on the network, tables on a rational
    fit), ``auto`` (exact loops refined, tables by the grid rule, so the
    report's tabulated examples are reproduced)."""
    found: list[Requirement] = []
    windings = []
    copies = (gain_as_stability, phase_as_stability)
    for c, condition in enumerate(problem.conditions):
        targets = [(i, t) for i, t in enumerate(problem.targets) if t.condition in (None, condition.name)]
        if not targets:
            windings.append(0.0)
            continue
        breaks = dict.fromkeys([condition.break_at] + [t.break_in(condition) for _, t in targets])
        for at in breaks:  # the primary break's loop first: its winding is the stability guard
            read = [(i, t) for i, t in targets if t.break_in(condition) == at]
            made, loop = _at_break(problem, x, c, at, read, detection, copies)
            found += made
            if at == condition.break_at:
                windings.append(winding(loop.gh))
    return sorted(found, key=_tableau_order), windings


def _at_break(
    problem: Problem,
    x: NDArray,
    c: int,
    at: str,
    targets: list[tuple[int, Target]],
    detection: str,
    copies: tuple[bool, bool],
) -> tuple[list[Requirement], LoopModel]:
    """The requirements of the targets read at the break ``at`` of condition ``c`` (the loop
    broken there, every other loop closed), and that loop."""
    condition = problem.conditions[c]
    loop = _loop(problem, c, problem.condition_values(c, x), detection != "grid", at)
    if not np.all(np.isfinite(loop.gh)):
        bad = problem.grid.omega[np.flatnonzero(~np.isfinite(loop.gh))[0]]
        raise EngineError(
            f"cip: the open loop of {condition.name} at {at} is not finite at {bad:.6g} rad/s "
            "(a value out of floating-point range, or a pole on the grid)"
        )
    above = min((t.detect_low for _, t in targets if KIND[t.measure] == "A"), default=None)
    found_margins = margins(loop, attenuation_above=above, method="fitted" if detection == "refined" else "grid")
    made = _requirements(found_margins.all(), targets, c, *copies, found_margins.label)
    from engine.cip.peaks import peak_requirements  # Mt and disk margins (family D); peaks.py imports Requirement

    made += peak_requirements(loop, targets, c)
    if at != condition.break_at:
        made = [replace(r, loop_break=at) for r in made]
    return made, loop


def _loop(problem: Problem, c: int, params: dict[str, float], refined: bool, at: str) -> LoopModel:
    """Condition ``c``'s loop broken at ``at``: refined (exact loops), else on the grid (a loop with
    tables: the response of the design's loop model, the one the plots read, solved once)."""
    network = problem.conditions[c].network
    if refined and network.exact:
        return loop_model(network, at, problem.grid.omega, params)
    if not network.exact and network.sample_time is None:
        return LoopModel(problem.grid.omega, loop_model(network, at, problem.grid.omega, params).gh)
    gh = open_loop(network, at, problem.grid.omega, params, sensitivities=False, check=False).value
    return LoopModel(problem.grid.omega, gh)  # the grid was checked when the problem was made


def winding(gh: NDArray) -> float:
    """Net turns of 1 + GH about the origin along the grid (sampled)."""
    phase = np.unwrap(np.angle(1.0 + gh))
    return float((phase[-1] - phase[0]) / (2 * math.pi))


SECTION_ORDER = {"G": 0, "P": 1, "copy": 2, "S": 3, "D": 4, "A": 5}


def _tableau_order(c: Requirement) -> tuple:
    section = "copy" if "<" in c.family else c.kind
    return (c.condition, SECTION_ORDER[section], c.family.split("@")[0], c.frequency)


def _requirements(
    found: tuple[Margin, ...],
    targets: list[tuple[int, Target]],
    c: int,
    gain_as_stability: bool,
    phase_as_stability: bool,
    method: str = "grid",
) -> list[Requirement]:
    out: list[Requirement] = []
    stability_targets = [(i, t) for i, t in targets if KIND[t.measure] == "S"]
    for i, target in targets:
        kind = KIND[target.measure]
        for m in found:
            if m.kind == kind and target.detect_low <= m.frequency <= target.detect_high:
                made = _requirement(m, target, f"{target.measure}#{i}@{c}", c, method)
                if made is not None:
                    out.append(made)
    copies = [k for k, wanted in (("G", gain_as_stability), ("P", phase_as_stability)) if wanted]
    copied = [made for made in out if made.kind in copies]
    for made in copied:
        for i, target in stability_targets:
            margin = Margin("S", made.frequency, made.value, made.gh)
            copy = _requirement(margin, target, f"stability_margin#{i}@{c}<{made.kind}", c, method)
            if copy is not None:
                out.append(copy)
    taken = {(made.frequency, made.family.split("<")[0]) for made in out if "<" in made.family}
    return [
        made for made in out if "<" in made.family or made.kind != "S" or (made.frequency, made.family) not in taken
    ]


def _requirement(m: Margin, target: Target, family: str, c: int, method: str = "grid") -> Requirement | None:
    desired = target.desired(m.frequency)
    if desired is None:
        return None
    value, shown = m.value, m.value
    shown_desired, goal = desired, desired
    if target.measure == "phase_margin_deg":
        shown, goal = math.degrees(2 * math.asin(min(m.value, 2.0) / 2)), 2 * math.sin(math.radians(desired) / 2)
    elif target.measure == "gain_margin_db":
        shown, goal = m.gain_db, 1.0 - 10.0 ** (-desired / 20.0)
    elif target.measure == "sensitivity_peak":  # Ms <= M: the stability margin |1 + GH| >= 1/M
        shown, goal = (1.0 / m.value if m.value > 0 else math.inf), (1.0 / desired if desired > 0 else math.inf)
    points = target.points or DEFAULT_POINTS[KIND[target.measure]]
    return Requirement(
        family,
        KIND[target.measure],
        target.measure,
        c,
        m.frequency,
        value,
        goal,
        shown,
        shown_desired,
        target.weight,
        points,
        m.gh,
        method,
    )

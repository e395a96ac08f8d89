"""`cip`: the Compensator Improvement Program of report 000 as a stepper.

One `step` is one accepted iteration of the listing's main loop:
  1. the margins at the current coefficients are known (from the last step);
     if none is active, all requirements are met;
  2. the direction D = G'(G G')^-1 c of the active requirements (direction.py),
     with coefficients held at their bounds;
  3. a trial move x + h D/|D| (clipped to the bounds), margins detected again;
     the move is accepted when it improves every active margin (TIFR) or
     their sum (SIFR); otherwise h is halved and the trial repeated from the
     same coefficients, down to the minimum step;
  4. after an accepted move h grows by `growth` (the listing's 1.41416; the
     text says doubling), capped at the maximum step.
The best coefficients so far (largest smallest relative-stability margin,
the listing's IBEST) are kept in the state and reported.

Departures from the listing, each a strict improvement and recorded here:
margins are matched from one iteration to the next by kind, target and
nearest frequency (the listing matched grid indices, so a margin that moved
by one grid point escaped the ratchet); a requirement that became satisfied
counts its gain in the SIFR sum; a move that changes the number of turns of
1 + GH about the origin along the grid (closed-loop stability changes) is
rejected (`stability_guard`); the run never ends on a rejected trial point;
identical gradient rows are not duplicated when a copied margin and its
original are both active.  Beyond the report: the problem's linear
constraints are held like bounds and a trial is projected onto them
(linear.py); without them every step is the report's.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from engine.cip.direction import COMPROMISE, MOVING, REPORT, Direction, Rows, compromise_direction, gradient_rows
from engine.cip.linear import held_direction, held_labels, trial_point
from engine.cip.memory import CipBest, CipMemory
from engine.cip.requirements import Requirement, check_targets, detect
from engine.design.constraints import check_start
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.model.compensators import coefficient_roles, compensators, split_by_role
from engine.stepping.guard import check_vector, guarded
from engine.stepping.protocol import BoundStepper, MeasureRow, State, Status, StepRecord

TERMINATION_STATUS = {
    "theorem2": Status.INFEASIBLE,
    "dependent": Status.NO_IMPROVEMENT,
    "zero_gradient": Status.NO_IMPROVEMENT,
}


@dataclass(frozen=True)
class CipSettings:
    """The listing's inputs (names in parentheses) and this program's options."""

    mode: Literal["tifr", "sifr"] = "sifr"  # continuance criterion (chapter VI, a or b)
    max_step: float = 0.1  # STPMAX
    min_step: float = 1e-4  # STPMIN
    initial_step: float | None = None  # default: the maximum step, as the listing
    growth: float = 1.41416  # step factor after an accepted move
    max_iterations: int = 200  # KQUIT
    detection: Literal["auto", "grid", "refined"] = "auto"  # auto: refined on exact loops, grid on tables
    gain_as_stability: bool = False  # INCGMS
    phase_as_stability: bool = False  # INCPMS
    tolerance: float = 0.0  # TIFR slack (the listing: 1e-5, single precision)
    guard_band: float = 0.0  # met margins this close (relative) to desired also steer D
    keep_met: bool = False  # reject a move that makes a met margin unmet
    hold_tolerance: float = 1e-5  # a coefficient this close to a bound is "at" it
    stability_guard: bool = True
    tracking: bool = True  # when the report's D finds no step, try D with the crossings moving (direction.py)

    def __post_init__(self) -> None:
        if self.mode not in ("tifr", "sifr"):
            raise EngineError(f"cip: mode must be 'tifr' or 'sifr', not {self.mode!r}")
        if self.detection not in ("auto", "grid", "refined"):
            raise EngineError(f"cip: detection must be 'auto', 'grid' or 'refined', not {self.detection!r}")
        if not (0 < self.min_step <= self.max_step):
            raise EngineError("cip: need 0 < min_step <= max_step")
        if self.initial_step is not None and not self.initial_step > 0:
            raise EngineError("cip: initial_step must be > 0")
        if not self.guard_band >= 0.0:
            raise EngineError("cip: guard_band must be >= 0")
        if not self.growth >= 1.0:
            raise EngineError("cip: growth must be >= 1")
        if self.max_iterations < 1:
            raise EngineError("cip: max_iterations must be >= 1")


class Cip(BoundStepper):
    """The stepper (see the module docstring)."""

    name = "cip"
    memory_type = CipMemory
    settings: CipSettings

    @guarded("cip")
    def setup(self) -> None:
        problem = self.problem
        check_targets(problem)
        if not problem.free_slots():
            raise EngineError("cip: no free coefficients to vary")
        self.lower, self.upper = problem.bounds()
        self._roles = coefficient_roles(problem.conditions[0].network)
        x = problem.vector()
        outside = np.flatnonzero((x < self.lower) | (x > self.upper))
        if outside.size:
            raise EngineError(f"cip: {self._slot_names()[outside[0]]} = {x[outside[0]]:.6g} is outside its bounds")
        check_start(problem, x, "cip")

    @guarded("cip")
    def init(self) -> State:
        settings, x = self.settings, self.problem.vector()
        requirements, windings = self._detect(x)
        step = settings.max_step if settings.initial_step is None else min(settings.initial_step, settings.max_step)
        memory = CipMemory(
            tuple(requirements),
            tuple(windings),
            step,
            sum(c.active for c in requirements),
            CipBest(0, tuple(x.tolist()), smallest_stability_margin(requirements)),
        )
        return State(0, tuple(x.tolist()), Status.RUNNING, memory)

    @guarded("cip")
    def step(self, state: State) -> tuple[State, StepRecord]:
        check_vector("cip", state.x, len(self.lower))
        x = np.array(state.x, dtype=float)
        memory: CipMemory = state.memory
        requirements = list(memory.requirements)
        active = [c for c in requirements if c.active]
        k = state.iteration + 1
        if not active:
            return self._stop(state, Status.CONVERGED, "all system requirements have been met", requirements)
        labels_of = {id(c): _label(c, n) for n, c in enumerate(requirements, start=1)}
        rejected: dict[str, int] = {}
        first, searched = None, []  # the first direction, and the names of those searched
        for how, direction in self._directions(x, requirements, active, labels_of):
            first = first or direction
            if direction.vector is None:
                continue
            searched.append((how, direction))
            outcome = self._search(x, memory.step, direction.vector, requirements, active, memory.windings, rejected)
            if outcome is not None:
                trial, h, (new, windings, matched) = outcome
                return self._accepted(state, k, trial, new, windings, matched, h, direction, rejected, len(active), how)
        assert first is not None
        names = [how for how, _ in searched]
        if first.vector is None:
            tried = f"; {names[0]} found no accepted step either" if names else ""
            return self._stop(
                state,
                TERMINATION_STATUS[first.termination],
                first.reason + tried,
                requirements,
                termination=first.termination,
                rejected=rejected,
            )
        return self._stop(
            state,
            Status.STEP_BELOW_MINIMUM,
            f"step size fell below the minimum {self.settings.min_step:g} after {sum(rejected.values())} trials"
            + (f" ({', then '.join(names)})" if len(names) > 1 else ""),
            requirements,
            direction=searched[-1][1].vector,
            rejected=rejected,
        )

    def _directions(
        self, x: NDArray, requirements: list[Requirement], active: list[Requirement], labels_of: dict
    ) -> Iterator[tuple[str, Direction]]:
        """The directions tried in turn, each named: the report's D, then (exact loops, `tracking`)
        D with the crossings moving or, where the report stops on Theorem 2 in sifr mode, the
        least-squares compromise (direction.py)."""
        steering = active + self._near(requirements)
        report = self._direction(x, steering, active, labels_of, tracking=False)
        yield REPORT, report
        if not self._tracks():
            return
        if report.termination == "theorem2":
            if self.settings.mode == "sifr":
                rows = _distinct(gradient_rows(self.problem, x, active, tracking=True))
                s = self.settings
                yield COMPROMISE, compromise_direction(rows, x, self.lower, self.upper, s.hold_tolerance)
            return
        yield MOVING, self._direction(x, steering, active, labels_of, tracking=True)

    def _direction(
        self, x: NDArray, steering: list[Requirement], active: list[Requirement], labels_of: dict, tracking: bool
    ) -> Direction:
        """The report's D over the steering rows (the guard band's rows dropped when they leave
        more rows than coefficients), with bounds and linear constraints held."""
        rows = _distinct(gradient_rows(self.problem, x, steering, tracking))
        if rows.gradients.shape[0] > x.size and len(steering) > len(active):
            steering = active  # guard rows are optional
            rows = _distinct(gradient_rows(self.problem, x, steering, tracking))
        labels = [labels_of[id(c)] for c in steering]
        return held_direction(
            rows, x, self.lower, self.upper, self.settings.hold_tolerance, labels, *self.problem.linear_constraints
        )  # the report's D when no requirement is held

    def _search(
        self,
        x: NDArray,
        h: float,
        direction: NDArray,
        requirements: list[Requirement],
        active: list[Requirement],
        windings: tuple[float, ...],
        rejected: dict[str, int],
    ) -> tuple[NDArray, float, tuple] | None:
        """Trial moves along ``direction``, h halved after each rejection (counted in ``rejected``),
        down to the minimum step: the accepted (point, h, outcome), or None."""
        while h >= self.settings.min_step:
            trial = trial_point(x, h, direction, *self.problem.linear_constraints, self.lower, self.upper)
            outcome = self._trial(trial, requirements, active, windings)
            if not isinstance(outcome, str):
                return trial, h, outcome
            rejected[outcome] = rejected.get(outcome, 0) + 1
            h /= 2.0
        return None

    def _tracks(self) -> bool:
        """Whether a second direction, the crossings moving, may be tried (exact loops only)."""
        return self.settings.tracking and all(c.network.exact for c in self.problem.conditions)

    @guarded("cip")
    def initial_record(self, state: State) -> StepRecord:
        """The tableau before any iteration (the report's Table 1), as iteration 0."""
        x = np.array(state.x)
        memory: CipMemory = state.memory
        requirements = list(memory.requirements)
        return StepRecord(
            0,
            state.status,
            self.problem.named(x),
            _rows(self.problem, requirements),
            step_size=memory.step,
            extra=self._extra(x, requirements, memory, sum(c.active for c in requirements)),
        )

    # -- pieces of a step --------------------------------------------------

    def _near(self, requirements: list[Requirement]) -> list[Requirement]:
        """Met margins within the guard band of their desired value."""
        band = self.settings.guard_band
        return [
            c
            for c in requirements
            if not c.active and band > 0 and abs(c.value - c.desired) < band * max(abs(c.desired), 1e-12)
        ]

    def _detect(self, x: NDArray) -> tuple[list[Requirement], list[float]]:
        s = self.settings
        return detect(self.problem, x, s.detection, s.gain_as_stability, s.phase_as_stability)

    def _trial(
        self, trial: NDArray, old: list[Requirement], active: list[Requirement], windings: tuple[float, ...]
    ) -> tuple[list[Requirement], list[float], list] | str:
        """The requirements at an accepted trial point, or why it was rejected."""
        try:
            new, new_windings = self._detect(trial)
        except EngineError:
            return "unusable"  # e.g. a denominator that vanishes on the grid
        if self.settings.stability_guard and any(abs(a - b) >= 0.5 for a, b in zip(windings, new_windings)):
            return "stability_changed"
        matched = match_requirements(old, new, active)
        if not improved(matched, self.settings.mode, self.settings.tolerance):
            return "not_improved"
        if self.settings.keep_met and any(n.active for o, n in match_requirements(old, new, old) if not o.active):
            return "met_margin_lost"
        return new, new_windings, matched

    def _accepted(
        self,
        state: State,
        k: int,
        x: NDArray,
        requirements: list[Requirement],
        windings: list[float],
        matched: list,
        h: float,
        direction: Direction,
        rejected: dict[str, int],
        before: int,
        how: str,
    ) -> tuple[State, StepRecord]:
        """The record and state of an accepted move; ``how`` names the direction taken."""
        s = self.settings
        best = state.memory.best
        smallest = smallest_stability_margin(requirements)
        if smallest is not None and (best.smallest is None or smallest > best.smallest):
            best = CipBest(k, tuple(x.tolist()), smallest)
        status, reason = Status.RUNNING, ""
        if not any(c.active for c in requirements):
            status, reason = Status.CONVERGED, "all system requirements have been met"
        elif k >= s.max_iterations:
            status, reason = (
                Status.ITERATION_LIMIT,
                f"maximum iterations ({s.max_iterations}); the last step {h:.3g} (the maximum {s.max_step:g}): "
                f"{sum(c.active for c in requirements)} requirement(s) unmet, raise max_iterations to go on",
            )
        memory = replace(
            state.memory,
            requirements=tuple(requirements),
            windings=tuple(windings),
            step=min(h * s.growth, s.max_step),
            best=best,
        )
        new_state = State(k, tuple(x.tolist()), status, memory)
        names = self._slot_names()
        extra = self._extra(x, requirements, memory, before) | {
            "matched": [
                {
                    "kind": o.kind,
                    "frequency": o.frequency,
                    "before": o.value,
                    "after": n.value,
                    "active_after": n.active,
                }
                for o, n in matched
            ],
            "held": [names[i] for i in np.flatnonzero(direction.held)] + held_labels(self.problem, direction),
            "partials": self._split(dict(zip(names, direction.vector.tolist()))),
            "direction": how,
        }
        record = StepRecord(
            k,
            status,
            self.problem.named(x),
            _rows(self.problem, requirements),
            step_size=h,
            direction=tuple(direction.vector.tolist()),
            counters=_counters(rejected, accepted=True),
            reason=reason,
            extra=extra,
        )
        return new_state, record

    def _stop(
        self,
        state: State,
        status: Status,
        reason: str,
        requirements: list[Requirement],
        *,
        termination: str = "",
        direction: NDArray | None = None,
        rejected: dict[str, int] | None = None,
    ) -> tuple[State, StepRecord]:
        """End without moving: the record shows the current coefficients."""
        x = np.array(state.x)
        k = state.iteration + 1
        before = sum(c.active for c in requirements)
        extra = self._extra(x, requirements, state.memory, before) | {"termination": termination}
        if direction is not None:
            extra["partials"] = self._split(dict(zip(self._slot_names(), direction.tolist())))
        record = StepRecord(
            k,
            status,
            self.problem.named(x),
            _rows(self.problem, requirements),
            step_size=state.memory.step,
            direction=() if direction is None else tuple(direction.tolist()),
            counters=_counters(rejected or {}, accepted=False),
            reason=reason,
            extra=extra,
        )
        return State(k, state.x, status, state.memory), record

    def _extra(self, x: NDArray, requirements: list[Requirement], memory: CipMemory, before: int) -> dict:
        best = memory.best
        return {
            "unmet": sum(c.active for c in requirements),
            "unmet_start": memory.unmet_start,
            "unmet_before": before,
            "smallest_stability_margin": smallest_stability_margin(requirements),
            "best": {
                "iteration": best.iteration,
                "smallest_stability_margin": best.smallest,
                "parameters": self.problem.named(best.x),
            },
            "compensators": [c.to_json() for c in self._compensators(x)],
        }

    def _compensators(self, x: NDArray):
        return compensators(self.problem.conditions[0].network, self.problem.condition_values(0, x))

    def _split(self, values: dict[str, float]) -> dict[str, dict[str, float]]:
        return split_by_role(self._roles, values)

    def _slot_names(self) -> list[str]:
        p = self.problem
        return [
            p.parameters[i].name if c is None else f"{p.parameters[i].name}[{p.conditions[c].name}]"
            for i, c in p.free_slots()
        ]


def _counters(rejected: dict[str, int], accepted: bool) -> dict[str, int]:
    """Trial moves made (each one margin detection) and why the rejected ones were."""
    trials = sum(rejected.values()) + accepted
    return {"trials": trials, "evaluations": trials} | {f"rejected_{k}": v for k, v in rejected.items()}


def smallest_stability_margin(requirements: list[Requirement]) -> float | None:
    """The smallest relative-stability margin (G, P or S distance from -1)."""
    values = [c.value for c in requirements if c.kind in ("G", "P", "S")]
    return min(values) if values else None


def match_requirements(old: list[Requirement], new: list[Requirement], chosen: list[Requirement]) -> list:
    """(old, new) pairs for the ``chosen`` old requirements: same family,
    mutually nearest in log frequency."""

    def by_family(pool: list[Requirement]) -> dict[str, tuple[list[Requirement], NDArray]]:
        groups: dict[str, list[Requirement]] = {}
        for c in pool:
            groups.setdefault(c.family, []).append(c)
        return {f: (cs, np.log(np.maximum([c.frequency for c in cs], 1e-300))) for f, cs in groups.items()}

    olds, news = by_family(old), by_family(new)
    pairs = []
    for o in chosen:
        if o.family not in news:
            continue
        candidates, positions = news[o.family]
        here = math.log(max(o.frequency, 1e-300))
        n = candidates[int(np.argmin(np.abs(positions - here)))]
        back, back_positions = olds[o.family]
        if back[int(np.argmin(np.abs(back_positions - math.log(max(n.frequency, 1e-300)))))] is o:
            pairs.append((o, n))
    return pairs


def improved(pairs: list, mode: str, tolerance: float) -> bool:
    """TIFR: no matched active margin that is still unmet got worse, and the
    sum improved; SIFR: the sum improved.  Nothing matched: accepted (the
    listing's rule when every margin moved)."""
    if not pairs:
        return True
    deltas = [n.goodness - o.goodness for o, n in pairs]
    if mode == "tifr" and any(d < -tolerance and n.active for d, (_, n) in zip(deltas, pairs)):
        return False
    return sum(deltas) > 0


def _distinct(rows: Rows) -> Rows:
    """Drop repeated gradient rows (a copied margin and its original, both active)."""
    keys = np.column_stack([np.round(rows.gradients, 12), rows.weights])
    seen: set[bytes] = set()
    keep = []
    for i, key in enumerate(keys):
        if key.tobytes() not in seen:
            seen.add(key.tobytes())
            keep.append(i)
    if len(keep) == len(keys):
        return rows
    return Rows(rows.gradients[keep], rows.weights[keep], tuple(rows.owners[i] for i in keep), rows.distances[keep])


def _label(c: Requirement, number: int) -> str:
    return f"margin {number} ({c.kind} at {c.frequency / (2 * math.pi):.5g} Hz)"


def _rows(problem: Problem, requirements: list[Requirement]) -> tuple[MeasureRow, ...]:
    return tuple(
        MeasureRow(
            f"{n}@{c.loop_break}" if c.loop_break else str(n),  # a row at another break names it
            c.measure,
            problem.conditions[c.condition].name,
            c.shown,
            c.shown_desired,
            not c.active,
            c.frequency,
            c.shown_at_least,
            c.method,
        )
        for n, c in enumerate(requirements, start=1)
    )

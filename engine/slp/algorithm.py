"""`slp`: COEBRA's sequential linear programming (report 003, chapter 2) as a stepper.

A major iteration linearizes every measure at its point x0 (partials.py);
its minor loop then tries step sizes P with those partials: each trial solves
the LP of lp.py (the inner loop lowering STEP until it is feasible) and
evaluates the measures at x0 + dx on the true responses.  A trial is better
than the best so far when the met-measure counter rises, or, on a tie, when
the figure of merit rises by at least `improvement_percent`.  P grows by
`step_growth` while trials are better; after a worse trial it is bisected
between the best P and the failed one (Figures 2-6 to 2-9) until the bracket
is within `step_resolution`.  The next major iteration relinearizes at the
best point; a major iteration that finds nothing better ends the run (self-
termination, section 2.10).  One `step` is one minor-loop trial.

Objective (section 2.3): Y1 = sum W1 W2 S dM/dx dx over all rows, with W1
the ratio desired/actual (actual/desired for at-most rows; |phase|/90 for
the phase at a modal peak, so modes are driven toward 0 deg), W2 the target
weight and S its scale; or (section 2.4, `objective = "load_relief"`) Y2,
minimizing the peak responses and mean squares while every margin stays a
constraint.  Figure of merit: sum W2 S min(M, desired) (capped at the
desired values), or minus the weighted peaks for load relief.

Readings and departures, each recorded here: W1 is undefined by the report
for measures of either sign (a gain margin in dB of an unstable loop); there
W1 = 1 + (desired - actual)/max(|desired|, 1), and every W1 is kept within
[0, 10].  A closed-loop stability row (-max Re of the closed-loop poles > 0)
is added to every rational condition unless `require_stable` is off, and a
trial that loses stability is never better (the counter alone could trade
stability for two other measures).  The step box is +-P max(|x0|,
`step_floor` times the variable's range) so that a variable at zero can move
when the floor is set (the report's box, floor 0, freezes it).  A met requirement is held in the LP
`backoff` (1 %) of its size above SPEC: the LP's solution is a vertex where
held rows are exactly active, so without it the linearization's second-order
error tips them just under SPEC and the trial loses a measure (seen on the
launch-vehicle example, where every trial near the boundary was rejected).
Beyond the report: the problem's linear constraints A x <= b are rows of every
LP (lp.py) and a trial is x0 + dx projected onto them and the bounds
(`engine.design.constraints.project`: the clip, unless HiGHS's rounding left a row off).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from engine.design.constraints import check_start, project, unmet
from engine.design.measure_kinds import Role, absence_role, absent_reason, surrogate_sign
from engine.errors import EngineError
from engine.slp.lp import LpResult, solve_step, step_box
from engine.slp.measures import Spec, absent_row, evaluate, measure_specs
from engine.slp.memory import SlpMemory, SlpPoint
from engine.slp.partials import jacobian
from engine.slp.surrogates import loop_level_db, surrogate_row
from engine.stepping.guard import check_vector, guarded
from engine.stepping.protocol import BoundStepper, MeasureRow, State, Status, StepRecord

LOAD_KINDS = ("peak_response", "mean_square")
STILL = "the linear program does not move"


@dataclass(frozen=True)
class SlpSettings:
    """The report's inputs and this program's options."""

    objective: Literal["margins", "load_relief"] = "margins"  # Y1 (2-11) or Y2 (2-12)
    partials: Literal["analytic", "finite_difference"] = "analytic"
    initial_step: float = 0.2  # P of the first trial
    step_growth: float = 2.0  # P after a better trial (before the bracket closes)
    min_step: float = 1e-3  # a minor loop whose P falls below this gives up
    max_step: float = 10.0
    step_resolution: float = 0.1  # bracket width (relative) that ends a minor loop
    step_floor: float = 0.0  # the box is +-P max(|x0|, step_floor * the variable's range)
    relaxation_step: float = 0.2  # STEP = 1, 1 - this, ..., 0 in the inner loop
    backoff: float = 0.01  # met rows are held this fraction of |SPEC| above SPEC (0: the report)
    improvement_percent: float = 0.1  # a tie in the counter needs this much more figure of merit
    max_minor: int = 12
    max_major: int = 30
    require_stable: bool = True
    fd_step: float = 1e-6  # relative forward-difference step

    RETIRED: ClassVar[dict[str, str]] = {
        "time_limit": "a wall-clock limit made a run impossible to replay; give it to the run instead "
        "(loopcraft run --time-limit SECONDS, or run_session(..., time_limit=SECONDS))"
    }

    def __post_init__(self) -> None:
        if not 0 < self.relaxation_step <= 1:
            raise EngineError("relaxation_step must lie in (0, 1]")
        if not (0 < self.min_step <= self.initial_step <= self.max_step):
            raise EngineError("need 0 < min_step <= initial_step <= max_step")
        if self.step_growth <= 1 or not 0 < self.step_resolution < 1:
            raise EngineError("step_growth must exceed 1 and step_resolution lie in (0, 1)")


@dataclass(frozen=True)
class Point:
    """A design point with its measure values, met-measure counter and figure of merit."""

    x: NDArray[np.float64]
    values: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    counter: int
    merit: float
    stable: bool


class Slp(BoundStepper):
    """The sequential linear programming stepper (see the module docstring)."""

    name = "slp"
    memory_type = SlpMemory
    settings: SlpSettings

    @guarded("slp")
    def setup(self) -> None:
        problem, settings = self.problem, self.settings
        self.specs = measure_specs(problem, settings.require_stable)
        if not problem.conditions:
            raise EngineError("slp needs at least one flight condition")
        if not any(s.target is not None for s in self.specs):
            raise EngineError("slp needs targets (performance measures)")
        if settings.objective == "load_relief" and not any(s.kind in LOAD_KINDS for s in self.specs):
            raise EngineError("the load-relief objective needs peak_response or mean_square targets")
        self.lower, self.upper = problem.bounds()
        self.equalities = problem.equality_system()
        self.inequalities = problem.linear_constraints

    @guarded("slp")
    def init(self) -> State:
        problem, settings = self.problem, self.settings
        x = self._feasible_start(np.clip(problem.vector(), self.lower, self.upper))
        check_start(problem, x, "slp")
        start = _stored(self._point(x))
        return State(
            0,
            tuple(x.tolist()),
            Status.RUNNING,
            SlpMemory(
                major=1,
                minor=0,
                x0=tuple(x.tolist()),
                base=start,
                best=start,
                partials=None,
                partial_methods=(),
                P=settings.initial_step,
                P_best=0.0,
                P_failed=None,
                evaluations=1,
                lps=0,
            ),
        )

    # -- one minor-loop trial ----------------------------------------------

    @guarded("slp")
    def step(self, state: State) -> tuple[State, StepRecord]:
        memory: SlpMemory = state.memory
        check_vector("slp", state.x, len(self.lower))
        check_vector("slp", memory.x0, len(self.lower))
        x0 = np.array(memory.x0)
        base = _point_from(memory.base)
        counters = {"partial_evaluations": 0}
        if memory.partials is None:
            J, how = jacobian(
                self.problem,
                x0,
                self.specs,
                base.values,
                base.frequencies,
                self.settings.partials,
                self.settings.fd_step,
            )
            memory = replace(memory, partials=tuple(map(tuple, J.tolist())), partial_methods=tuple(how))
            counters["partial_evaluations"] = len(x0) if "finite difference" in how else 1
        J = np.array(memory.partials, dtype=float)
        if J.shape != (len(self.specs), len(x0)):
            raise EngineError(
                f"slp: the state's partials are {' x '.join(map(str, J.shape))}, the problem needs "
                f"{len(self.specs)} x {len(x0)} (the stored state belongs to another problem)"
            )
        P = float(memory.P)
        lp = self._program(x0, base.values, base.frequencies, J, P, memory.capped)
        trial, reason = self._trial(x0, lp)
        better = trial is not None and self._better(trial, _point_from(memory.best))
        memory = replace(
            memory,
            minor=memory.minor + 1,
            lps=memory.lps + lp.solves,
            evaluations=memory.evaluations + (trial is not None),
        )
        memory = replace(memory, best=_stored(trial), P_best=P) if better else replace(memory, P_failed=P)
        numbers = (memory.major, memory.minor)
        done, why, memory = self._next_step(memory, reason == STILL)
        status, shown = Status.RUNNING, trial
        if done:
            status, reason, final, memory = self._end_major(memory, why, reason)
            shown = final or trial
        shown = shown or base
        record = self._record(
            state.iteration + 1, status, shown, memory, numbers, lp, P, trial, better, reason, counters
        )
        x = memory.best.x if status.finished else memory.x0
        return State(state.iteration + 1, x, status, memory), record

    def _trial(self, x0: NDArray, lp: LpResult) -> tuple[Point | None, str]:
        if lp.dx is None:
            return None, f"no feasible program even with STEP = 0 ({lp.status})"
        if np.all(np.abs(lp.dx) <= 1e-14 * np.maximum(np.abs(x0), 1.0)):
            return None, STILL
        try:
            x = project(x0 + lp.dx, *self.inequalities, self.lower, self.upper)  # the clip, or the LP's rounding off
            return self._point(x), ""
        except (EngineError, np.linalg.LinAlgError, ValueError) as exc:
            return None, f"trial point cannot be evaluated: {exc}"

    def _next_step(self, memory: SlpMemory, still: bool) -> tuple[bool, str, SlpMemory]:
        """Update P (grow, or bisect the bracket); True when the minor loop is over
        (a program that does not move will not move with another P either)."""
        s = self.settings
        P_best, P_failed = memory.P_best, memory.P_failed
        if still:
            return True, STILL, memory
        if self._complete(_point_from(memory.best)):
            return True, "nothing left to improve", memory
        if memory.minor >= s.max_minor:
            return True, "minor-loop limit", memory
        if P_failed is None:
            if P_best >= s.max_step:
                return True, "largest step", memory
            return False, "", replace(memory, P=min(P_best * s.step_growth, s.max_step))
        if P_best > 0 and P_failed - P_best <= s.step_resolution * P_failed:
            return True, "step size resolved", memory
        memory = replace(memory, P=0.5 * (P_best + P_failed))
        if memory.P < s.min_step:
            return True, "step below minimum", memory
        return False, "", memory

    def _end_major(self, memory: SlpMemory, why: str, reason: str) -> tuple[Status, str, Point | None, SlpMemory]:
        """Start the next major iteration at the best point, or end the run."""
        best, base = _point_from(memory.best), _point_from(memory.base)
        s = self.settings
        improved = not np.array_equal(best.x, base.x)
        if self._complete(best):  # not improved: complete at the start, nothing to reward
            reached = "every requirement met and every desired value reached" + ("" if improved else " at the start")
            return Status.CONVERGED, reached, best, memory
        if not improved and self._retry_capped(memory, best):
            memory = replace(memory, major=memory.major + 1, minor=0, P=s.initial_step, P_failed=None, capped=True)
            retry = "retry with the objective capped at the desired values (rows past theirs left out)"
            return (
                Status.RUNNING,
                f"major iteration {memory.major - 1} found no better point ({why}); {retry}",
                None,
                memory,
            )
        probed = None if improved else self._probe(best)
        if probed is not None:  # a step of one parameter the linear program did not see: taken
            memory = replace(memory, best=_stored(probed), evaluations=memory.evaluations + 2 * probed.x.size)
            improved, why = True, f"{why}; a step of {s.min_step:g} (relative) in one parameter is better"
        if not improved:
            rule = f"a trial must meet more requirements or raise the figure of merit by {s.improvement_percent:g} %"
            return (
                Status.NO_IMPROVEMENT,
                f"major iteration {memory.major} found no better point ({why}; {rule})",
                best,
                memory,
            )
        if memory.major >= s.max_major:
            return Status.ITERATION_LIMIT, f"major-iteration limit ({s.max_major})", best, memory
        memory = replace(
            memory,
            major=memory.major + 1,
            minor=0,
            x0=memory.best.x,
            base=memory.best,
            partials=None,
            P=max(memory.P_best, s.min_step),
            P_best=0.0,
            P_failed=None,
        )
        return Status.RUNNING, reason or f"relinearize at the best point ({why})", None, memory

    def _probe(self, best: Point) -> Point | None:
        """The first step of `min_step` (relative) in one free parameter, up or down, within the
        bounds and constraints, that is better than ``best`` by the trials' own rule (`_better`):
        what a run that found nothing better tries before it stops (2 n evaluations)."""
        for i, sign in itertools.product(range(best.x.size), (1.0, -1.0)):
            x = best.x.copy()
            x[i] *= 1.0 + sign * self.settings.min_step
            if not self.lower[i] <= x[i] <= self.upper[i] or unmet(self.problem, x):
                continue
            try:
                point = self._point(x)
            except (EngineError, np.linalg.LinAlgError, ValueError):
                continue
            if self._better(point, best):
                return point
        return None

    def _retry_capped(self, memory: SlpMemory, best: Point) -> bool:
        """Whether a major iteration that found nothing better is tried again with the objective
        capped: once, with requirements unmet.  The report's Y1 rewards every row, a phase margin
        far past its desired value too, which the figure of merit (capped) does not: the LP heads
        where no trial is better, and an unmet crossover is given up."""
        unmet = best.counter < sum(spec.required is not None for spec in self.specs)
        return (
            unmet
            and not memory.capped
            and self.settings.objective == "margins"
            and memory.major < self.settings.max_major
        )

    # -- the linear program ------------------------------------------------

    def _program(
        self, x0: NDArray, values: NDArray, frequencies: NDArray, J: NDArray, P: float, capped: bool = False
    ) -> LpResult:
        s = self.settings
        signs = np.array([spec.sign for spec in self.specs])
        oriented, gradients = signs * values, signs[:, None] * J
        roles = self._roles(values, frequencies)
        present = np.isfinite(oriented) & np.array([role == "steered" for role in roles], dtype=bool)
        for i, role in enumerate(roles):  # an unmet feature the loop lacks: its surrogate's level, toward 0
            found = (
                surrogate_row(self.problem, x0, self.specs[i], values[i], s.fd_step) if role == "surrogate" else None
            )
            if found is not None:
                oriented[i], gradients[i] = found[0], found[1]
                present[i] = True
        rows = [i for i, spec in enumerate(self.specs) if spec.required is not None and present[i]]
        specs = np.array(
            [0.0 if roles[i] == "surrogate" else self.specs[i].sign * self.specs[i].required for i in rows]
        )
        steps = np.append(np.arange(1.0, 0.0, -s.relaxation_step), 0.0)
        box = step_box(x0, self.lower, self.upper, P, s.step_floor)
        c = self._objective(values, gradients, present, roles, capped)
        result = solve_step(
            c, gradients[rows], oriented[rows], specs, box, self.equalities, x0, steps, s.backoff, self.inequalities
        )
        duals = np.zeros(len(self.specs))
        duals[rows] = result.duals if result.duals.size == len(rows) else 0.0
        return LpResult(result.dx, result.step, result.solves, result.status, duals)

    def _objective(
        self, values: NDArray, gradients: NDArray, present: NDArray, roles: list[Role], capped: bool
    ) -> NDArray:
        """The LP's objective vector: Y1 (weighted measure gains) or -Y2 (weighted peaks); a
        surrogate row's gain is its level's, in dB; ``capped``: rows past their desired value
        left out (`_retry_capped`)."""
        c = np.zeros(gradients.shape[1])
        for i, spec in enumerate(self.specs):
            if not present[i] or spec.weight == 0:
                continue
            if roles[i] == "surrogate":
                c += spec.weight * gradients[i]
            elif self.settings.objective == "load_relief":
                if spec.kind in LOAD_KINDS:
                    c += spec.weight * spec.scale * gradients[i]
            elif spec.desired is not None and not (capped and spec.sign * values[i] >= spec.sign * spec.desired):
                c += w1(spec, values[i]) * spec.weight * spec.scale * gradients[i]
        return c

    # -- points, counters, figure of merit ---------------------------------

    def _point(self, x: NDArray) -> Point:
        return self.point_at(x, *evaluate(self.problem, x, self.specs))

    def point_at(self, x: NDArray, values: NDArray, frequencies: NDArray) -> Point:
        """The point at ``x`` whose rows (`specs`) have these values and frequencies: its
        met-measure counter, figure of merit and stability (a batch of samples evaluated
        elsewhere, `sessions.sweeps.batch_study`, is recorded as a point is)."""
        counter = sum(spec.met(v) for spec, v in zip(self.specs, values) if spec.required is not None)
        stable = all(
            v > 0 for spec, v in zip(self.specs, values) if spec.kind == "stability_abscissa" and spec.target is None
        )
        merit = self._merit(values, self._judged(values, frequencies))
        return Point(np.asarray(x, dtype=float), values, frequencies, int(counter), merit, stable)

    def _roles(self, values: NDArray, frequencies: NDArray) -> list[Role]:
        """Each row's part under the absence rule (`engine.design.measure_kinds.absence_role`)."""
        return [
            absence_role(spec.kind, absent_row(spec, v, f), spec.met(v))
            for spec, v, f in zip(self.specs, values, frequencies)
        ]

    def _judged(self, values: NDArray, frequencies: NDArray) -> frozenset[int]:
        """The rows met on a feature the loop lacks: judged only, no term of the figure of merit."""
        return frozenset(i for i, role in enumerate(self._roles(values, frequencies)) if role == "judged")

    def _merit(self, values: NDArray, judged: frozenset[int] = frozenset()) -> float:
        total = 0.0
        for i, (spec, v) in enumerate(zip(self.specs, values)):
            if i in judged:
                continue
            if self.settings.objective == "load_relief":
                if spec.kind in LOAD_KINDS and math.isfinite(v):
                    total += spec.weight * spec.scale * spec.sign * v
                continue
            if spec.desired is None or spec.weight == 0 or math.isnan(v):
                continue  # a NaN (an error, an undefined measure) earns nothing: it is never met
            total += spec.weight * spec.scale * min(spec.sign * v, spec.sign * spec.desired)
        return float(total)

    def _complete(self, point: Point) -> bool:
        """Every requirement met and the figure of merit at its cap (nothing left to reward)."""
        if self.settings.objective == "load_relief":
            return False
        met = all(spec.met(v) for spec, v in zip(self.specs, point.values))
        at_cap = all(
            spec.desired is None or spec.weight == 0 or math.isnan(v) or spec.sign * v >= spec.sign * spec.desired
            for spec, v in zip(self.specs, point.values)
        )
        return met and at_cap

    def _better(self, trial: Point, best: Point) -> bool:
        if best.stable and not trial.stable:
            return False
        if np.array_equal(trial.x, best.x):
            return False
        if trial.counter != best.counter:
            return trial.counter > best.counter
        if not (best.stable or trial.stable):  # two unstable loops: the one nearer stability is better
            nearer, now = self._stability(trial), self._stability(best)
            return nearer > now + self.settings.improvement_percent / 100.0 * max(abs(now), 1e-12)
        trial_merit, best_merit = self._comparable_merits(trial, best)
        if not math.isfinite(best_merit):  # -inf (an unstable loop's peak): any finite merit is better
            return trial_merit > best_merit
        movable = abs(best_merit - self._held_at_cap(trial, best))
        return trial_merit > best_merit + self.settings.improvement_percent / 100.0 * max(movable, 1e-12)

    def _held_at_cap(self, trial: Point, best: Point) -> float:
        """The part of the figure of merit from rows at their desired value at both points: a
        constant of the comparison, left out of the scale of the improvement a tie needs (else a
        met phase margin, or several conditions' of them, outweighs what a step earns and every
        trial is refused)."""
        if self.settings.objective == "load_relief":
            return 0.0
        judged = self._judged(trial.values, trial.frequencies) | self._judged(best.values, best.frequencies)
        total = 0.0
        for i, spec in enumerate(self.specs):
            if i in judged or spec.desired is None or spec.weight == 0:
                continue
            cap = spec.sign * spec.desired
            if spec.sign * trial.values[i] >= cap and spec.sign * best.values[i] >= cap:
                total += spec.weight * spec.scale * cap
        return total

    def _stability(self, point: Point) -> float:
        """The least stability abscissa of the point's conditions (`require_stable`'s rows)."""
        rows = [
            v for spec, v in zip(self.specs, point.values) if spec.kind == "stability_abscissa" and spec.target is None
        ]
        return float(min(rows, default=math.inf))

    def _comparable_merits(self, trial: Point, best: Point) -> tuple[float, float]:
        """The two points' figures of merit on the same rows: a row judged only at either point
        (met on a feature one of them lacks) left out of both, and a row steered by its surrogate
        at both points compared on the surrogate's level (weighted, in dB)."""
        roles = list(zip(self._roles(trial.values, trial.frequencies), self._roles(best.values, best.frequencies)))
        judged = frozenset(i for i, pair in enumerate(roles) if "judged" in pair)
        surrogate = [i for i, pair in enumerate(roles) if pair == ("surrogate", "surrogate")]
        if judged == self._judged(best.values, best.frequencies) == self._judged(trial.values, trial.frequencies):
            trial_merit, best_merit = trial.merit, best.merit
        else:
            trial_merit, best_merit = self._merit(trial.values, judged), self._merit(best.values, judged)
        for i in surrogate:
            spec = self.specs[i]
            rise = loop_level_db(self.problem, trial.x, spec) - loop_level_db(self.problem, best.x, spec)
            if math.isfinite(rise):
                trial_merit += spec.weight * surrogate_sign(best.values[i]) * rise
        return trial_merit, best_merit

    def _feasible_start(self, x: NDArray) -> NDArray:
        """The start moved onto the linear equalities (least change), if it is off them."""
        A, b = self.equalities
        if not A.size or np.allclose(A @ x, b, rtol=1e-9, atol=1e-12):
            return x
        moved = np.clip(x - np.linalg.pinv(A) @ (A @ x - b), self.lower, self.upper)
        if not np.allclose(A @ moved, b, rtol=1e-6, atol=1e-9):
            raise EngineError("the linear equalities cannot be met within the parameter bounds")
        return moved

    # -- records -------------------------------------------------------------

    def rows(self, point: Point) -> tuple[MeasureRow, ...]:
        """The tableau of a point: every row with its requirement and whether it is met."""
        return tuple(MeasureRow(*fields) for fields in self.row_fields(point))

    def row_fields(self, point: Point) -> list[tuple]:
        """Each row of `rows` as the tuple of its `MeasureRow` fields, in their order (a batch of
        samples, `sessions.sweeps.batch_study`, writes them as JSON without making the rows)."""
        out = []
        for spec, v, f in zip(self.specs, point.values, point.frequencies):
            out.append(
                (
                    spec.name,
                    spec.kind,
                    self.problem.conditions[spec.condition].name,
                    float(v),
                    spec.required,
                    bool(spec.met(v)),
                    None if math.isnan(f) else float(f),
                    spec.at_least,
                    absent_reason(spec.kind, float(v)) if absent_row(spec, v, f) else None,
                )
            )
        return out

    @guarded("slp")
    def initial_record(self, state: State) -> StepRecord:
        """Iteration 0: the tableau of the starting point."""
        start = _point_from(state.memory.base)
        return StepRecord(
            0,
            Status.RUNNING,
            self.problem.named(start.x),
            self.rows(start),
            objective=start.merit,
            extra={"counter": start.counter, "figure_of_merit": start.merit, "desired": self._desired()},
        )

    def _desired(self) -> list[float | None]:
        return [spec.desired for spec in self.specs]

    def _record(
        self,
        iteration: int,
        status: Status,
        shown: Point,
        memory: SlpMemory,
        numbers: tuple[int, int],
        lp: LpResult,
        P: float,
        trial: Point | None,
        better: bool,
        reason: str,
        counters: dict,
    ) -> StepRecord:
        names = [f"{s.name}@{self.problem.conditions[s.condition].name}" for s in self.specs]
        extra = {
            "major": numbers[0],
            "minor": numbers[1],
            "P": P,
            "STEP": lp.step,
            "lp_status": lp.status,
            "accepted": better,
            "counter": shown.counter,
            "figure_of_merit": shown.merit,
            "trial_counter": None if trial is None else trial.counter,
            "trial_figure_of_merit": None if trial is None else trial.merit,
            "best_counter": memory.best.counter,
            "best_figure_of_merit": memory.best.merit,
            "duals": dict(zip(names, lp.duals.tolist())),
            "partials": dict(zip(names, memory.partial_methods)),
            "desired": self._desired(),
            "stable": shown.stable,
        }
        counters = dict(counters, evaluations=memory.evaluations, lps=memory.lps)
        dx = () if lp.dx is None else tuple(float(v) for v in lp.dx)
        return StepRecord(
            iteration,
            status,
            self.problem.named(shown.x),
            self.rows(shown),
            objective=shown.merit,
            step_size=P,
            direction=dx,
            counters=counters,
            reason=reason,
            extra=extra,
        )


def w1(spec: Spec, value: float) -> float:
    """The report's weight W1: desired over actual (> 1 when unmet), kept within [0, 10]."""
    if spec.kind == "modal_peak_phase_deg":
        return min(value / 90.0, 10.0)
    desired = spec.desired
    if desired > 0 and value > 0:
        ratio = desired / value if spec.at_least else value / desired
    else:
        ratio = 1.0 + spec.sign * (desired - value) / max(abs(desired), 1.0)
    return float(np.clip(ratio, 0.0, 10.0))


def _stored(point: Point) -> SlpPoint:
    """A point as the memory keeps it (tuples)."""
    return SlpPoint(
        tuple(point.x.tolist()),
        tuple(point.values.tolist()),
        tuple(point.frequencies.tolist()),
        point.counter,
        point.merit,
        point.stable,
    )


def _point_from(stored: SlpPoint) -> Point:
    """A point from memory, as arrays."""
    return Point(
        np.array(stored.x, dtype=float),
        np.array(stored.values, dtype=float),
        np.array(stored.frequencies, dtype=float),
        stored.counter,
        stored.merit,
        stored.stable,
    )

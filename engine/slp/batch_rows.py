"""slp's time rows (`engine.slp.measures`: step measures and the peak response) and the
closed-loop stability abscissa of many samples of one problem at once: each sample's closed
loop realized as the per-loop path realizes it (`engine.loop.design.closed_loop_realization`;
all at once when the network allows, `engine.loop.batch_realization`), the realizations stacked, every sample's response to a target's profile simulated in one
recursion (`engine.closed_loop.batch_time`) and read by the per-loop path's own rules
(`engine.slp.measures.response_value`); the abscissa from one batched eigenvalue call on
the stacked closed-loop matrices (each the per-loop path's own matrix).

A loop in z is realized per sample (its realization in w, as the per-loop path makes it), its
responses stepped in z at its samples for all of them at once
(`engine.closed_loop.batch_time.batch_simulate_sampled`), its abscissa the poles' s-plane
equivalents.  A sample whose
realization fails, or whose realization is not of the study's shape, gets no values (the
per-loop path takes it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.batch_time import batch_simulate, batch_simulate_sampled
from engine.closed_loop.time_response import Segment
from engine.design.problem import Problem
from engine.errors import EngineError
from engine.loop.batch_realization import SharedStateSpace, batch_loop_realization, closed_of, samples
from engine.loop.design import closed_loop_realization, seed_loop_realization
from engine.loop.realization import StateSpace, unstable_rows
from engine.model.bilinear import s_of_z, z_of_w
from engine.slp.measures import Spec, evaluate, response_times, response_value

# the time rows read from a simulated response (a mean square solves a Lyapunov equation: per loop)
RESPONSE_FLOATS = 1 << 20  # responses' samples held at once (8 MB): a loop in z's horizon may be 10^6 samples
BATCH_TIME_KINDS = frozenset(
    ("peak_response", "overshoot_percent", "settling_time", "rise_time", "peak_time", "steady_state_error")
)


Stacks = tuple[StateSpace, StateSpace]  # a condition's broken and closed loops, every sample's


def batch_time_rows(
    problem: Problem,
    specs: Sequence[Spec],
    xs: NDArray[np.float64],
    stacks: Mapping[int, Stacks | None] | None = None,
    stability: bool = False,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Per sample (rows of the free vectors ``xs``): the values of ``specs``' time rows and the
    stability rows of conditions with time rows (of every condition with ``stability``; NaN in
    the other columns), and whether the sample has them all (else the per-loop path takes it).
    ``stacks``: the conditions' realizations already made (`condition_stacks`)."""
    values = np.full((xs.shape[0], len(specs)), np.nan)
    ok = np.ones(xs.shape[0], dtype=bool)
    kinds = (*BATCH_TIME_KINDS, "stability_abscissa")
    wanted = {s.condition for s in specs if s.kind in BATCH_TIME_KINDS or (stability and s.kind == kinds[-1])}
    for c in sorted(wanted):
        rows = [i for i, s in enumerate(specs) if s.condition == c and s.kind in kinds]
        made = stacks[c] if stacks is not None and c in stacks else condition_stacks(problem, c, xs)
        realized = samples(made[1]) if made is not None else [_realized(problem, c, x) for x in xs]
        hidden = made[1].hidden if made is not None and isinstance(made[1], SharedStateSpace) else None
        ok &= _condition_rows(problem, realized, [specs[i] for i in rows], values, rows, hidden)
    return values, ok


def condition_stacks(problem: Problem, c: int, xs: NDArray) -> Stacks | None:
    """Condition ``c``'s broken and closed loops of every sample at once (`engine.loop.batch_realization`:
    the per-loop path's matrices); None when the network does not allow it."""
    condition = problem.conditions[c]
    if condition.network.sample_time is not None:
        return None  # a loop in z: realized per sample (its realization in w, `_realized`)
    values = [problem.condition_values(c, x) for x in xs]
    columns = {name: np.array([v[name] for v in values]) for name in values[0]} if values else {}
    broken = batch_loop_realization(condition.network, condition.break_at, columns) if columns else None
    closed = None if broken is None else closed_of(condition.network, condition.break_at, broken)
    return None if broken is None or closed is None else (broken, closed)


def _condition_rows(
    problem: Problem,
    realized: list[StateSpace | None],
    specs: list[Spec],
    values: NDArray,
    rows: list[int],
    hidden: NDArray[np.complex128] | None = None,
) -> NDArray[np.bool_]:
    """A condition's rows of every sample (its closed loops ``realized``, ``hidden``: the poles of
    the states they share, `SharedStateSpace`) written to ``values``' columns ``rows``; which
    samples have them."""
    shape = next((ss.A.shape for ss in realized if ss is not None), None)
    ok = np.array([ss is not None and ss.A.shape == shape and np.isfinite(ss.A).all() for ss in realized])
    if shape is None or not ok.any():
        return ok
    mine = np.flatnonzero(ok)
    loops = [realized[k] for k in mine]
    A = np.array([ss.A for ss in loops])
    eigenvalues = np.linalg.eigvals(A) if A.shape[1] else np.zeros((A.shape[0], 0), dtype=complex)
    if hidden is not None:
        eigenvalues = np.concatenate([eigenvalues, hidden[mine]], axis=1)
    unstable = unstable_rows(
        eigenvalues
    )  # `engine.slp.measures.grows`' verdict, per sample (in w: the same half-plane)
    sample_time = loops[0].sample_time
    for spec, column in zip(specs, rows):
        if spec.kind == "stability_abscissa":
            values[mine, column] = _abscissa(eigenvalues, sample_time)
            continue
        response = problem.targets[spec.target].response
        first = loops[0]
        if response.input not in first.inputs or response.output not in first.outputs:
            return np.zeros_like(ok)  # the per-loop path says what is wrong
        k, j = first.inputs.index(response.input), first.outputs.index(response.output)
        t = response_times(response, sample_time)
        segments = [Segment(*p) for p in response.profile]
        B, C = np.array([ss.B[:, k] for ss in loops]), np.array([ss.C[j] for ss in loops])
        D = np.array([ss.D[j, k] for ss in loops])
        group = max(1, RESPONSE_FLOATS // max(1, t.size))  # samples simulated at once: memory bounded
        for first in range(0, len(loops), group):
            part = slice(first, first + group)
            with np.errstate(all="ignore"):
                if sample_time is None:
                    y = batch_simulate(A[part], B[part], C[part], D[part], t, segments)
                else:
                    y = batch_simulate_sampled(A[part], B[part], C[part], D[part], t, segments, sample_time)
            for row, (sample, ss) in enumerate(zip(mine[part].tolist(), loops[part])):
                values[sample, column] = response_value(spec, response, ss, t, y[row], unstable[part][row])
    return ok


def _abscissa(eigenvalues: NDArray, sample_time: float | None) -> NDArray:
    """-max Re of every sample's closed-loop poles (`engine.design.tableau.stability_abscissa`: a
    sampled loop's poles in w taken to their s-plane equivalents)."""
    if sample_time is not None:
        with np.errstate(all="ignore"):
            eigenvalues = s_of_z(z_of_w(eigenvalues), sample_time)
    return -np.max(eigenvalues.real, axis=1, initial=-math.inf)


def _realized(problem: Problem, c: int, x: NDArray) -> StateSpace | None:
    """Condition ``c``'s closed loop at the free values ``x``, as the per-loop path realizes it; None when that fails."""
    condition = problem.conditions[c]
    try:
        return closed_loop_realization(condition.network, condition.break_at, problem.condition_values(c, x))
    except (EngineError, ValueError, np.linalg.LinAlgError):
        return None


@dataclass(frozen=True)
class Assisted:
    """A chunk of samples evaluated per loop with their realizations, time rows and stability rows
    made for all at once (`assisted`): what slp's measures (`engine.slp.measures.evaluate`)
    compute per sample, the frequency rows per sample on the batched realizations."""

    problem: Problem
    specs: Sequence[Spec]
    stacks: Mapping[int, Stacks]
    values: NDArray[np.float64]  # (S, rows): the batched rows' values, NaN elsewhere
    ok: NDArray[np.bool_]  # the samples whose batched rows are had
    batched: NDArray[np.bool_]  # (rows,): which rows the batch gives

    def evaluate(self, k: int, x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Sample ``k``'s (values, frequencies) at the free values ``x`` (its row of the chunk)."""
        problem = self.problem
        for c, (broken, _) in self.stacks.items():
            condition = problem.conditions[c]
            # copies: a design the network keeps must not hold the whole chunk's stack
            matrices = (broken.A[k].copy(), broken.B[k].copy(), broken.C[k].copy(), broken.D[k].copy())
            own = StateSpace(*matrices, broken.inputs, broken.outputs)
            seed_loop_realization(condition.network, condition.break_at, problem.condition_values(c, x), own)
        rest = np.flatnonzero(~self.batched if self.ok[k] else np.ones(len(self.specs), dtype=bool))
        values, frequencies = self.values[k].copy(), np.full(len(self.specs), np.nan)
        if rest.size:
            values[rest], frequencies[rest] = evaluate(problem, x, [self.specs[i] for i in rest])
        return values, frequencies


def assisted(problem: Problem, specs: Sequence[Spec], xs: NDArray[np.float64]) -> Assisted | None:
    """The samples' realizations, time rows and stability rows made at once, for a study whose
    frequency rows go per loop (a loop that is not one cascade); None when a condition has no
    batched realization (`condition_stacks`) or is sampled."""
    if any(condition.network.sample_time is not None for condition in problem.conditions):
        return None
    stacks = {c: condition_stacks(problem, c, xs) for c in range(len(problem.conditions))}
    made = {c: stack for c, stack in stacks.items() if stack is not None}
    if len(made) < len(stacks):
        return None
    values, ok = batch_time_rows(problem, specs, xs, made, stability=True)
    batched = np.array([s.kind in BATCH_TIME_KINDS or s.kind == "stability_abscissa" for s in specs], dtype=bool)
    return Assisted(problem, specs, made, values, ok, batched)

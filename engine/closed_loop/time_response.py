"""Time responses of a rational interconnection and their classical measures
(report 003, section 1.3): rise time 10-90 %, delay time 50 %, peak time,
overshoot, settling time (band, default 5 %), steady-state error, peak |x|.

Inputs are piecewise linear (steps, ramps and sequences of them, e.g. a wind
profile); the state equation is integrated exactly for such inputs with the
first-order-hold discretization exp([[A, B, 0], [0, 0, I], [0, 0, 0]] h).
Runs of equal steps are propagated in blocks (`_scan`: a few matrix
products per block instead of one per step).

The measures read the response against its final value, which the caller
gives: the closed loop's DC gain times the final input when the loop is
stable and the input settles (`final_value`), else y at the horizon, and
`StepMeasures.final_from` says which.  Definitions (``r = y / final``), and
how python-control's step_info (0.10) differs:

- rise time: from r = 0.1 to r = 0.9, delay time: to r = 0.5, each the first
  crossing, interpolated linearly between samples (step_info: the first
  sample at or above each level; within one time step); a sampled loop's
  (``held``: its output held between samples) the first sample at or above
  each level, no interpolation;
- peak, peak time, overshoot: by ``peak_rule`` -- ``"global"`` (default) the
  largest r over the horizon, ``"first_half_cycle"`` report 003's rule, the
  largest r of the first half cycle above the final value (from the first
  sample above it to the next at or below it: a structural mode's ripple on
  the rise does not end the half cycle, its crest is not the peak); no peak time and 0 % when the
  rule finds no sample above the final value (step_info: overshoot from the
  largest r, peak and peak time those of the largest |y|, also without
  overshoot, so they differ when an undershoot exceeds the overshoot);
- settling time: the last time |r - 1| > band, interpolated linearly between
  the last sample outside and the first inside (step_info: that first sample
  inside; within one time step); ``held``: that first sample inside, after
  which every sample stays in the band; None when still outside at the horizon.

A continuous loop's step plot and report refine these on the exact response
(`engine.closed_loop.step_response`); what is interpolated here is what slp's
time rows read on their grid.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import EngineError
from engine.loop.realization import StateSpace

PeakRule = Literal["global", "first_half_cycle"]
FinalFrom = Literal["dc_gain", "horizon"]
PEAK_RULES: tuple[PeakRule, ...] = ("global", "first_half_cycle")
Maps = TypeVar("Maps")
BLOCK = 64  # steps propagated together by `_scan`


@dataclass(frozen=True)
class Segment:
    """From ``time`` on, the input adds ``step`` at once and then ramps at ``slope`` per second."""

    time: float
    step: float = 0.0
    slope: float = 0.0


def input_profile(t: NDArray, segments: Sequence[Segment]) -> NDArray:
    """Sum of steps and ramps: u(t) = sum_k H(t - t_k)(step_k + slope_k (t - t_k))."""
    u = np.zeros_like(t)
    for seg in segments:
        on = t >= seg.time
        u[on] += seg.step + seg.slope * (t[on] - seg.time)
    return u


def simulate(ss: StateSpace, input_name: str, t: ArrayLike, segments: Sequence[Segment]) -> NDArray:
    """All signals (len(t), n_signals) for the given input profile, zero initial state.

    Grid points are added at every breakpoint so the hold is exact.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0) or t[0] != 0:
        raise EngineError("time grid must start at 0 and increase strictly")
    if input_name not in ss.inputs:
        raise EngineError(f"unknown input {input_name!r}; inputs are {', '.join(ss.inputs)}")
    k = ss.inputs.index(input_name)
    if ss.sample_time is not None:
        return _sampled(ss, k, t, segments)
    breaks = [s.time for s in segments if 0 < s.time < t[-1]]
    grid = np.unique(np.concatenate([t, breaks]))
    u = input_profile(grid, segments)
    # the value just before a breakpoint is the left limit of the input
    u_left = np.where(np.isin(grid, breaks), input_profile(np.nextafter(grid, -np.inf), segments), u)
    x = _propagate(ss.A, ss.B[:, k], grid, u, u_left)
    y = x @ ss.C.T + np.outer(u, ss.D[:, k])
    return y[np.isin(grid, t)]


MAX_SAMPLES = 1_000_000  # a sampled loop's samples in one response


def _sampled(ss: StateSpace, k: int, t: NDArray, segments: Sequence[Segment]) -> NDArray:
    """A sampled loop (its realization in w, taken to z) stepped at its samples t_j = j T, the input
    read at each sample; the signals held between samples (what a sampled loop is)."""
    from engine.model.bilinear import realization_in_z

    T = ss.sample_time
    count = math.floor(t[-1] / T + 1e-9) + 1
    if count > MAX_SAMPLES:
        raise EngineError(f"{t[-1]:g} s is {count} samples of {T:g} s: more than {MAX_SAMPLES} in one response")
    A, B, C, D = realization_in_z(ss.A, ss.B[:, k : k + 1], ss.C, ss.D[:, k : k + 1])
    u = input_profile(np.arange(count) * T, segments)
    x = np.zeros((count, A.shape[0]))
    if A.shape[0] and count > 1:
        x[1:] = _scan(A, x[0], np.outer(u[:-1], B[:, 0]))
    y = x @ C.T + np.outer(u, D[:, 0])
    return y[np.floor(t / T + 1e-9).astype(int)]


def _propagate(A: NDArray, B: NDArray, grid: NDArray, u: NDArray, u_left: NDArray) -> NDArray:
    """States on ``grid`` (rows) under the piecewise linear input, zero initial state."""
    n = A.shape[0]
    x = np.zeros((grid.size, n))
    if n == 0:
        return x
    h = np.diff(grid)
    du = (u_left[1:] - u[:-1]) / h
    for a, b, (Phi, Gam0, Gam1) in held_runs(grid, lambda step: _foh(A, B, step)):
        forced = np.outer(u[a:b], Gam0) + np.outer(du[a:b], Gam1)
        x[a + 1 : b + 1] = _scan(Phi, x[a], forced)
    return x


def held_runs(grid: NDArray, maps: Callable[[float], Maps]) -> list[tuple[int, int, Maps]]:
    """The runs of equal steps of ``grid`` (`equal_step_runs`), each with its step's one-step maps
    (``maps(step)``, made once per step)."""
    holds: dict[float, Maps] = {}
    out = []
    for a, b in equal_step_runs(grid):
        step = (grid[b] - grid[a]) / (b - a)
        if step not in holds:
            holds[step] = maps(step)
        out.append((a, b, holds[step]))
    return out


def equal_step_runs(grid: NDArray) -> list[tuple[int, int]]:
    """Maximal ranges [a, b) of steps grid[i+1] - grid[i] equal to the rounding of the
    grid's times (4 eps |t|: the jitter of a linspace), the others one step each."""
    h = np.diff(grid)
    tol = 4 * np.finfo(float).eps * np.abs(grid[1:])
    cut = np.flatnonzero(np.abs(np.diff(h)) > tol[1:]) + 1
    bounds = np.concatenate([[0], cut, [h.size]]).astype(int)
    runs: list[tuple[int, int]] = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        if np.ptp(h[a:b]) <= tol[b - 1]:
            runs.append((int(a), int(b)))
        else:  # a slow drift of the step: no common step
            runs.extend((i, i + 1) for i in range(a, b))
    return runs


def _scan(Phi: NDArray, x0: NDArray, forced: NDArray) -> NDArray:
    """x[k+1] = Phi x[k] + forced[k] from x[0] = x0: the states x[1:].

    In blocks of BLOCK steps: the powers Phi^1..Phi^BLOCK by doubling, the
    zero-state part of every block by one doubling scan over all blocks at once,
    the block starts by the exact recursion with Phi^BLOCK, the free part by one
    product with the stacked powers.
    """
    L, n = forced.shape
    if L == 1:
        return x0 @ Phi.T + forced
    m = min(BLOCK, L)
    nb = -(-L // m)
    powers = Phi.T[None]  # powers[k] = (Phi^(k+1))^T
    while powers.shape[0] < m:
        powers = np.concatenate([powers, flush_subnormal(powers @ powers[-1])])
    z = np.zeros((nb * m, n))
    z[:L] = forced
    z = z.reshape(nb, m, n)
    d = 1
    while d < m:
        z[:, d:] = z[:, d:] + z[:, :-d] @ powers[d - 1]
        d *= 2
    starts = np.empty((nb, n))
    starts[0] = x0
    for b in range(1, nb):
        starts[b] = starts[b - 1] @ powers[m - 1] + z[b - 1, -1]
    free = (starts @ powers[:m].transpose(1, 0, 2).reshape(n, m * n)).reshape(nb, m, n)
    return (free + z).reshape(nb * m, n)[:L]


def flush_subnormal(P: NDArray) -> NDArray:
    """P with the entries below 1e-250 set to 0 (no subnormal products: they are slow)."""
    P[np.abs(P) < 1e-250] = 0.0
    return P


def _foh(A: NDArray, B: NDArray, h: float) -> tuple[NDArray, NDArray, NDArray]:
    """Exact one-step maps for an input linear over [0, h]: x+ = Phi x + G0 u0 + G1 du."""
    n = A.shape[0]
    big = np.zeros((n + 2, n + 2))
    big[:n, :n], big[:n, n], big[n, n + 1] = A * h, B * h, 1.0
    from scipy.linalg import expm  # on first use (start-up)

    E = expm(big)
    return E[:n, :n], E[:n, n], E[:n, n + 1] * h


def final_value(
    ss: StateSpace, input_name: str, output: str, segments: Sequence[Segment], y: NDArray
) -> tuple[float, FinalFrom]:
    """The final value of ``output`` (response ``y``) and where it comes from: the DC
    gain times the final input when the closed loop is stable and the input
    settles (slopes summing to 0), else the last sample ``y[-1]``."""
    slopes = [s.slope for s in segments]
    settles = abs(sum(slopes)) <= 1e-12 * sum(abs(v) for v in slopes)
    stable = ss.A.size == 0 or bool(np.max(np.linalg.eigvals(ss.A).real) < 0)
    if not (stable and settles):
        return float(y[-1]), "horizon"
    level = sum(s.step - s.slope * s.time for s in segments)
    return float(dc_gain(ss, input_name)[ss.outputs.index(output)]) * level, "dc_gain"


@dataclass(frozen=True)
class StepMeasures:
    """Classical measures of a response to a step toward ``final`` (see the module's
    definitions); ``final_from``: "dc_gain" or "horizon" (y at the last sample)."""

    final: float
    rise_time: float | None
    delay_time: float | None
    peak_time: float | None
    peak: float
    overshoot_percent: float
    settling_time: float | None
    steady_state_error: float
    final_from: FinalFrom = "dc_gain"
    peak_rule: PeakRule = "global"


def step_measures(
    t: NDArray,
    y: NDArray,
    final: float,
    desired: float = 1.0,
    band: float = 0.05,
    *,
    final_from: FinalFrom = "dc_gain",
    peak_rule: PeakRule = "global",
    held: bool = False,
) -> StepMeasures:
    """Rise (10-90 %), delay (50 %), peak by ``peak_rule``, overshoot, settling within
    ``band`` of ``final`` (the caller's final value, see `final_value`); ``held``: a sampled
    loop's samples, each measure read on them (no interpolation between samples)."""
    if final == 0 or not math.isfinite(final):
        raise EngineError("step measures need a finite, non-zero final value")
    if peak_rule not in PEAK_RULES:
        raise EngineError(f"unknown peak rule {peak_rule!r}; rules are {', '.join(PEAK_RULES)}")
    r = np.asarray(y, dtype=float) / final
    crossing = _first_sample_at if held else _first_crossing
    t10, t90 = crossing(t, r, 0.1), crossing(t, r, 0.9)
    ipk = _peak_index(r, peak_rule)
    top = int(np.argmax(r)) if ipk is None else ipk
    return StepMeasures(
        final=float(final),
        rise_time=None if t10 is None or t90 is None else t90 - t10,
        delay_time=crossing(t, r, 0.5),
        peak_time=None if ipk is None else float(t[ipk]),
        peak=float(y[top]),
        overshoot_percent=0.0 if ipk is None else float((r[ipk] - 1.0) * 100.0),
        settling_time=_settling_time(t, r, band, held),
        steady_state_error=float(desired - final),
        final_from=final_from,
        peak_rule=peak_rule,
    )


def _first_crossing(t: NDArray, r: NDArray, level: float) -> float | None:
    """First time r reaches ``level``, interpolated between samples (None: never)."""
    idx = np.flatnonzero(r >= level)
    if idx.size == 0:
        return None
    i = idx[0]
    if i == 0:
        return float(t[0])
    return float(t[i - 1] + (level - r[i - 1]) * (t[i] - t[i - 1]) / (r[i] - r[i - 1]))


def _first_sample_at(t: NDArray, r: NDArray, level: float) -> float | None:
    """The first sample at or above ``level`` (None: never)."""
    idx = np.flatnonzero(r >= level)
    return None if idx.size == 0 else float(t[idx[0]])


def _peak_index(r: NDArray, rule: PeakRule) -> int | None:
    """The peak's sample by ``rule``, None when it finds none above the final value."""
    if rule == "first_half_cycle":  # the largest r of the first excursion above the final value
        above = np.flatnonzero(r > 1.0)
        if not above.size:
            return None
        start = int(above[0])
        back = np.flatnonzero(r[start:] <= 1.0)
        end = start + int(back[0]) if back.size else r.size
        return start + int(np.argmax(r[start:end]))
    i = int(np.argmax(r))
    return i if r[i] > 1.0 else None


def _settling_time(t: NDArray, r: NDArray, band: float, held: bool = False) -> float | None:
    """Last time |r - 1| > band, interpolated between the last sample outside and the
    next (inside), or that next sample itself when ``held``; t[0] when never outside,
    None when outside at the horizon."""
    outside = np.flatnonzero(np.abs(r - 1.0) > band)
    if outside.size == 0:
        return float(t[0])
    i = int(outside[-1])
    if i == r.size - 1:
        return None
    if held:
        return float(t[i + 1])
    level = 1.0 + band if r[i] > 1.0 else 1.0 - band
    return float(t[i] + (level - r[i]) * (t[i + 1] - t[i]) / (r[i + 1] - r[i]))


def dc_gain(ss: StateSpace, input_name: str) -> NDArray:
    """Final value of every signal for a unit step at ``input_name`` (stable systems)."""
    k = ss.inputs.index(input_name)
    if ss.A.size == 0:
        return ss.D[:, k]
    return ss.D[:, k] - ss.C @ np.linalg.solve(ss.A, ss.B[:, k])


@dataclass(frozen=True)
class DelayedRun:
    """A loop with delays stepped on a uniform grid (`simulate_delayed`): the times ``t`` (a time twice
    where a signal jumps: its left limit, then its right), every signal at them (rows)."""

    t: NDArray
    y: NDArray
    right: NDArray  # every signal just after each sample i step (rows)
    complete: bool = True  # False: a signal left the floating-point range, the samples before it kept


SHORT_DELAYS = 256  # more blocks of the shortest delay than this: the whole scheme as one recurrence
RECURRENCE_STATES = 128  # ... when its state (x and both limits of every delay's ring) is at most this


def simulate_delayed(
    ss: StateSpace,
    input_name: str,
    delays: Sequence[tuple[int, int, int]],
    step: float,
    count: int,
    how: Literal["auto", "blocks", "recurrence"] = "auto",
) -> DelayedRun:
    """A unit step at ``input_name`` of a loop whose delays are opened in ``ss`` (`realization.OpenedDelays`),
    on the grid t_i = i ``step`` (i < ``count``), zero initial state.  Each delay (samples, input, output)
    is a whole number of steps from the output signal to the input: a ring of past samples, both limits
    kept at each (a jump falls on a sample: the step at 0 and its echoes).  Between samples every input is
    linear (first-order hold), the state equation integrated exactly for it, so the error is O(step^2) where
    the signals are smooth between samples.  Computed a block of the shortest delay at a time (its inputs
    all known from the past: `_scan`), or, when the delays are short beside the horizon (more than
    `SHORT_DELAYS` blocks), as one affine recurrence on the state and the rings (`_rings_recurrence`: the
    same numbers, a few matrix products per 64 steps); ``how`` forces one way."""
    if not delays or min(d[0] for d in delays) < 1:
        raise EngineError("each delay must be a whole number (>= 1) of steps")
    k = ss.inputs.index(input_name)
    cols = [k] + [d[1] for d in delays]
    B, D = ss.B[:, cols], ss.D[:, cols]
    n, p = ss.A.shape[0], len(cols)
    Phi, G0, G1 = foh_maps(ss.A, B, step)
    lags = np.array([d[0] for d in delays])
    rows = [d[2] for d in delays]
    right = np.zeros((count, len(ss.outputs)))  # signals just after each sample
    left = np.zeros((count, len(ss.outputs)))  # just before (0 before the step at t = 0)
    x = np.zeros((count, n))
    u_right, u_left = np.zeros((count, p)), np.zeros((count, p))
    u_right[:, 0], u_left[1:, 0] = 1.0, 1.0

    def delayed(i0: int, i1: int) -> None:  # the delays' outputs at samples i0..i1-1 from the past
        for j, lag in enumerate(lags):
            src = np.arange(i0, i1) - lag
            on = src >= 0
            u_right[i0:i1, j + 1] = np.where(on, right[np.maximum(src, 0), rows[j]], 0.0)
            u_left[i0:i1, j + 1] = np.where(on, left[np.maximum(src, 0), rows[j]], 0.0)

    def signals(i0: int, i1: int) -> None:
        right[i0:i1] = x[i0:i1] @ ss.C.T + u_right[i0:i1] @ D.T
        left[i0:i1] = x[i0:i1] @ ss.C.T + u_left[i0:i1] @ D.T

    block = int(lags.min())
    size = n + 2 * int(lags.sum())
    ring = how == "recurrence" or (how == "auto" and count > SHORT_DELAYS * block and size <= RECURRENCE_STATES)
    delayed(0, 1)
    signals(0, 1)
    i0 = count - 1 if ring and count > 1 else 0
    if i0:
        with np.errstate(all="ignore"):
            x[1:], u_right[1:, 1:], u_left[1:, 1:] = _rings_recurrence(ss, k, delays, (Phi, G0, G1), step, count)
            signals(1, count)
    with np.errstate(all="ignore"):  # an unstable loop grows: shown until it leaves the float range
        while i0 < count - 1:
            i1 = min(i0 + block, count - 1)
            delayed(i0 + 1, i1 + 1)
            du = (u_left[i0 + 1 : i1 + 1] - u_right[i0:i1]) / step
            if n:
                x[i0 + 1 : i1 + 1] = _scan(Phi, x[i0], u_right[i0:i1] @ G0.T + du @ G1.T)
            signals(i0 + 1, i1 + 1)
            i0 = i1
    times = np.arange(count) * step
    complete = bool(np.all(np.isfinite(right)))
    if not complete:  # grown past the float range: the samples before it
        last = int(np.argmax(~np.all(np.isfinite(right), axis=1)))
        times, left, right, count = times[:last], left[:last], right[:last], last
    with np.errstate(all="ignore"):
        jumps = np.any(np.abs(left - right) > 1e-12 * (np.abs(left) + np.abs(right)), axis=1)
    jumps[0] = False  # at 0 the response starts from its right limit
    order = np.repeat(np.arange(count), np.where(jumps, 2, 1))
    first = np.concatenate([[True], order[1:] != order[:-1]])
    y = np.where((first & jumps[order])[:, None], left[order], right[order])
    return DelayedRun(times[order], y, right, complete)


def _rings_recurrence(
    ss: StateSpace, k: int, delays: Sequence[tuple[int, int, int]], maps: tuple[NDArray, ...], step: float, count: int
) -> tuple[NDArray, NDArray, NDArray]:
    """`simulate_delayed`'s scheme from sample 1 on as s+ = M s + f: s the state x, then per delay its input's
    last ``lag`` right limits, then their left limits (the step r = 1 from sample 1 on: constant forcing).
    The states and the delays' outputs (right and left limits) at samples 1 .. count - 1."""
    Phi, G0, G1 = maps
    n, lags, rows = ss.A.shape[0], [d[0] for d in delays], [d[2] for d in delays]
    total = sum(lags)
    size = n + 2 * total
    starts = n + np.cumsum([0] + lags)[:-1]
    eye = np.eye(size)
    X = eye[:n]
    Wp = np.array([eye[s + lag - 1] for s, lag in zip(starts, lags)])  # v(i - lag), right limits
    Wm = np.array([eye[total + s + lag - 1] for s, lag in zip(starts, lags)])  # left limits
    Cv, Dvr = ss.C[rows], ss.D[rows, k]
    Dvw = ss.D[np.ix_(rows, [d[1] for d in delays])]
    Vp, Vm = Cv @ X + Dvw @ Wp, Cv @ X + Dvw @ Wm  # the delays' inputs now, each + Dvr
    Wm_next = np.array(
        [Vm[j] if lag == 1 else eye[total + s + lag - 2] for j, (s, lag) in enumerate(zip(starts, lags))]
    )
    c_next = np.array([Dvr[j] if lag == 1 else 0.0 for j, lag in enumerate(lags)])
    G0w, G1w = G0[:, 1:], G1[:, 1:] / step
    M, f = np.zeros((size, size)), np.zeros(size)
    M[:n] = Phi @ X + G0w @ Wp + G1w @ (Wm_next - Wp)
    f[:n] = G0[:, 0] + G1w @ c_next
    for j, (s, lag) in enumerate(zip(starts, lags)):
        for base, V in ((s, Vp), (total + s, Vm)):
            M[base], f[base] = V[j], Dvr[j]
            M[base + 1 : base + lag, base : base + lag - 1] = np.eye(lag - 1)
    first = np.zeros(size)  # sample 1: x = G0 r (nothing delayed yet), the rings hold v(0+) = Dvr, v(0-) = 0
    first[:n] = G0[:, 0]
    first[starts] = Dvr
    s = np.empty((count - 1, size))
    s[0] = first
    if count > 2:
        s[1:] = _scan(M, first, np.tile(f, (count - 2, 1)))
    return s[:, :n], s @ Wp.T, s @ Wm.T


def delay_recurrence(ss: StateSpace, delays: Sequence[tuple[int, int, int]], step: float) -> NDArray:
    """The free (unforced) recurrence `simulate_delayed` steps, as one matrix on (x_i, and per delay its
    input's last ``samples`` values): its eigenvalues z approximate exp(lambda step) of the loop's
    characteristic roots lambda (the rightmost to O(step^2))."""
    n, lags = ss.A.shape[0], [d[0] for d in delays]
    starts = np.cumsum([n] + lags)[:-1]
    size = n + sum(lags)
    Phi, G0, G1 = foh_maps(ss.A, ss.B[:, [d[1] for d in delays]], step)
    rows = [d[2] for d in delays]
    W = np.zeros((len(delays), size))  # the delays' outputs now: their inputs lag samples ago
    for k, (lag, start) in enumerate(zip(lags, starts)):
        W[k, start + lag - 1] = 1.0
    X = np.zeros((n, size))
    X[:, :n] = np.eye(n)
    V = ss.C[rows] @ X + ss.D[np.ix_(rows, [d[1] for d in delays])] @ W  # the delays' inputs now
    W_next = np.zeros_like(W)
    for k, (lag, start) in enumerate(zip(lags, starts)):
        W_next[k] = V[k] if lag == 1 else np.eye(size)[start + lag - 2]
    M = np.zeros((size, size))
    M[:n] = Phi @ X + (G0 - G1 / step) @ W + (G1 / step) @ W_next
    for k, (lag, start) in enumerate(zip(lags, starts)):
        M[start] = V[k]
        M[start + 1 : start + lag, start : start + lag - 1] = np.eye(lag - 1)
    return M


def foh_maps(A: NDArray, B: NDArray, h: float) -> tuple[NDArray, NDArray, NDArray]:
    """Exact one-step maps for inputs linear over [0, h] (B: n x p): x+ = Phi x + G0 u0 + G1 du (du per s)."""
    n, p = B.shape
    big = np.zeros((n + 2 * p, n + 2 * p))
    big[:n, :n], big[:n, n : n + p], big[n : n + p, n + p :] = A * h, B * h, np.eye(p)
    from scipy.linalg import expm  # on first use (start-up)

    E = expm(big)
    return E[:n, :n], E[:n, n : n + p], E[:n, n + p :] * h

"""A closed loop's step response and its classical measures, as the workbench's step plot
and the design report show it.

The engineer chooses the input stepped and the output shown (`StepSetup`); by
default the first input and the output named y, c or x1.  The horizon, unless
given, comes from the closed-loop poles (8 time constants of the slowest, 5 of the
fastest unstable).  The measures: rise time (10-90 %), overshoot, settling band
(+-5 %) and settling time (`time_response.step_measures`), from the DC gain's final
value (none when the response has no settled final value to measure from).  A continuous
loop's are refined on the exact response y(t) = c x(t) + d, x(t) from
expm([[A, b], [0, 0]] t): the crossings of 10, 50 and 90 % and of the band by Brent's
method in their brackets on the grid, the peak where y'(t) = c (A x + b) vanishes (the
grid's largest local maxima refined), and the stationary points after the last sample
outside the band that come near it checked, so a brief excursion between samples counts.

A sampled loop (its realization in w, `StateSpace.sample_time`) responds at its samples
t = k T: its realization taken to z (w = (z - 1)/(z + 1)) and stepped sample by sample; the
response is drawn as a staircase (the output held between samples) and every measure read on
the samples (`step_measures(held=True)`: the peak the largest sample, rise from the first sample
at or above 10 % to the first at or above 90 %, settling the first sample after which every
sample stays in the band), over a horizon from the poles' radii (8 time constants -T/ln|z|
of the slowest).

A continuous loop with time delays exp(-tau s) has no finite realization: its response is simulated on
a grid whose step divides every delay, on two grids (h and h/2) whose difference estimates each measure's
error (`engine.closed_loop.delayed_step`); `StepResponse.errors` and `StepResponse.how` carry them, and
`network_step` picks the way for a design's network.  A continuous loop with tables is stepped with
each table's rational model, each measure's error estimated by the models of every other table point
(`engine.closed_loop.tabulated_step`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from engine.closed_loop.delayed_step import delayed_step
from engine.closed_loop.tabulated_step import has_tables, tabulated_step
from engine.closed_loop.time_response import Segment, StepMeasures, final_value, simulate, step_measures
from engine.errors import EngineError
from engine.loop.realization import StateSpace, realize
from engine.model.bilinear import s_of_z, z_of_w
from engine.model.blocks import DelayTransfer
from engine.model.network import Network

SAMPLES = 400  # at least, over the horizon
PER_PERIOD = 16  # samples per period of the fastest closed-loop oscillation, so no peak falls between brackets
MOST_SAMPLES = 20_000  # a continuous response's samples at most (then `StepResponse.note` says so)
MIN_SAMPLES, MAX_SAMPLES = 20, 2000  # a sampled loop's step response: samples shown
SETTLING_BAND = 0.05
MAX_HORIZON = 1e4


@dataclass(frozen=True)
class StepSetup:
    """What the step plot shows: None picks the default."""

    input: str | None = None
    output: str | None = None
    horizon: float | None = None


@dataclass(frozen=True)
class StepResponse:
    t: list[float]
    y: list[float]
    name: str  # 'y (step at r)'
    measures: StepMeasures | None  # None when the response has no settled final value to measure from
    note: str | None = None  # what the measures cannot promise (a grid too coarse for an oscillation)
    errors: Mapping[str, float] | None = None  # a simulated response's (a loop with delays): each measure's error
    how: str | None = None  # how a simulated response was obtained, and the curve's error


def has_delays(network: Network) -> bool:
    """Whether the network is a continuous loop with delays exp(-tau s) and rational blocks besides (no
    table): what `network_step` simulates."""
    return (
        network.sample_time is None
        and network.variable == "s"
        and any(isinstance(e.transfer, DelayTransfer) for e in network.entries)
        and all(e.transfer.rational_form or isinstance(e.transfer, DelayTransfer) for e in network.entries)
    )


def network_step(
    network: Network, params: Mapping[str, float], setup: StepSetup = StepSetup(), span: float | None = None
) -> StepResponse | None:
    """A design's step response: a rational loop's on its realization (`realized`, `step_response`: exact,
    its measures refined on the exact response), a continuous loop with delays simulated on a grid with
    each measure's error (`engine.closed_loop.delayed_step`), one with tables stepped with their rational
    models, each measure's error from the models of every other point (`engine.closed_loop.tabulated_step`);
    None for any other loop or when it cannot be computed."""
    if network.rational:
        ss = realized(network, params)
        return None if ss is None else step_response(ss, setup, span)
    if has_tables(network):
        return tabulated_step(network, lambda modelled, end: network_step(modelled, params, setup, end), span)
    if not has_delays(network) or not network.inputs:
        return None
    source = setup.input if setup.input in network.inputs else network.inputs[0]
    signals = network.signals
    output = (
        setup.output if setup.output in signals else next((n for n in ("y", "c", "x1") if n in signals), signals[-1])
    )
    try:
        found = delayed_step(network, params, source, output, setup.horizon or span)
    except EngineError:
        return None
    name = f"{output} (step at {source}, simulated)"
    return StepResponse(found.t.tolist(), found.y.tolist(), name, found.measures, found.note, found.errors, found.how)


def default_output(ss: StateSpace) -> str:
    """y, c or x1 when the network has one, else its last signal."""
    return next((name for name in ("y", "c", "x1") if name in ss.outputs), ss.outputs[-1])


def horizon(ss: StateSpace) -> float:
    """A step response's duration from the closed-loop poles' real parts (10 s when
    they cannot be computed; a sampled loop's from the s-plane equivalents of its poles,
    at least `MIN_SAMPLES` samples)."""
    try:
        eigenvalues = np.linalg.eigvals(ss.A)
    except np.linalg.LinAlgError:
        return 10.0
    real = eigenvalues.real
    if ss.sample_time is not None:
        real = s_of_z(z_of_w(eigenvalues), ss.sample_time).real
        real = real[np.isfinite(real)] if np.isfinite(real).any() else np.array([-1.0])
        shortest, longest = MIN_SAMPLES * ss.sample_time, MAX_SAMPLES * ss.sample_time
        return float(np.clip(_from_real_parts(real), shortest, longest))
    return _from_real_parts(real)


def _from_real_parts(real: np.ndarray) -> float:
    if real.max() > 0:
        return min(5.0 / real.max(), MAX_HORIZON)
    slowest = np.abs(real[real < 0]).min(initial=np.inf)
    return min(8.0 / slowest, MAX_HORIZON) if np.isfinite(slowest) else 10.0


def realized(network: Network, params: Mapping[str, float]) -> StateSpace | None:
    """The closed loop's state space (None when it has no state, cannot be realized or
    its matrix is not finite)."""
    try:
        ss = realize(network, params)
    except EngineError:
        return None
    return ss if ss.inputs and ss.A.size and np.all(np.isfinite(ss.A)) else None


def step_response(ss: StateSpace, setup: StepSetup, span: float | None = None) -> StepResponse | None:
    """The response of the chosen output to a unit step at the chosen input, over
    ``span`` (the setup's horizon, else this loop's own)."""
    source = setup.input if setup.input in ss.inputs else ss.inputs[0]
    output = setup.output if setup.output in ss.outputs else default_output(ss)
    end = setup.horizon or span or horizon(ss)
    if ss.sample_time is not None:
        return _sampled_step(ss, source, output, end)
    t = np.linspace(0.0, end, SAMPLES)
    try:
        y = _simulated(ss, source, output, t)
        count, note = _samples(ss, end)
        if count > SAMPLES and _measured(ss, source, output, y):  # a finer grid for the measures' brackets
            t = np.linspace(0.0, end, count)
            y = _simulated(ss, source, output, t)
        else:
            note = None
    except EngineError:
        return None
    measures = _measures(ss, source, output, t, y)
    return StepResponse(t.tolist(), y.tolist(), f"{output} (step at {source})", measures, note)


def _simulated(ss: StateSpace, source: str, output: str, t: np.ndarray) -> np.ndarray:
    return simulate(ss, source, t, [Segment(0.0, step=1.0)])[:, ss.outputs.index(output)]


RETURNS_TO_ZERO = 1e-6  # a final value this small beside the response's peak: a disturbance rejected


def _measured(ss: StateSpace, source: str, output: str, y: np.ndarray) -> bool:
    """Whether the response has step measures worth refining: finite, settling at a final value (the DC
    gain's) that is not 0 beside its peak."""
    if not np.all(np.isfinite(y)):
        return False
    final, origin = final_value(ss, source, output, [Segment(0.0, step=1.0)], y)
    return origin == "dc_gain" and math.isfinite(final) and abs(final) > RETURNS_TO_ZERO * np.max(np.abs(y))


def _samples(ss: StateSpace, end: float) -> tuple[int, str | None]:
    """Samples over ``end`` seconds: `PER_PERIOD` per period of the fastest oscillation of the closed
    loop, at least `SAMPLES`, at most `MOST_SAMPLES` (then a note says which oscillation is unresolved)."""
    try:
        fastest = float(np.max(np.abs(np.linalg.eigvals(ss.A).imag), initial=0.0))
    except np.linalg.LinAlgError:
        return SAMPLES, None
    wanted = math.ceil(end * fastest / (2 * math.pi) * PER_PERIOD) + 1 if math.isfinite(fastest) else SAMPLES
    if wanted <= MOST_SAMPLES:
        return max(SAMPLES, wanted), None
    return MOST_SAMPLES, (
        f"{MOST_SAMPLES} samples over {end:.6g} s do not resolve the {fastest:.6g} rad/s oscillation: "
        "a peak or an excursion from the band between samples may be missed"
    )


def _sampled_step(ss: StateSpace, source: str, output: str, end: float) -> StepResponse | None:
    """A sampled loop's step response at t = k T up to ``end`` (at most `MAX_SAMPLES` samples), as a
    staircase, measured at its samples (`time_response.simulate`)."""
    T = ss.sample_time
    count = int(min(MAX_SAMPLES, max(MIN_SAMPLES, math.ceil(end / T)))) + 1
    t = np.arange(count) * T
    with np.errstate(all="ignore"):  # an unstable loop grows: shown until it leaves the float range
        y = simulate(ss, source, t, [Segment(0.0, step=1.0)])[:, ss.outputs.index(output)]
    stairs_t, stairs_y = np.repeat(t, 2)[1:], np.repeat(y, 2)[:-1]
    name = f"{output} (step at {source}, every {T:g} s)"
    return StepResponse(stairs_t.tolist(), stairs_y.tolist(), name, _measures(ss, source, output, t, y))


def _measures(ss: StateSpace, source: str, output: str, t: np.ndarray, y: np.ndarray) -> StepMeasures | None:
    if not np.all(np.isfinite(y)):
        return None
    final, origin = final_value(ss, source, output, [Segment(0.0, step=1.0)], y)
    if origin != "dc_gain" or final == 0 or not math.isfinite(final):
        return None
    on_grid = step_measures(t, y, final, band=SETTLING_BAND, held=ss.sample_time is not None)
    if ss.sample_time is not None:
        return on_grid
    exact = ExactStep(ss, source, output)
    slope = simulate(replace(ss, C=ss.C @ ss.A, D=ss.C @ ss.B), source, t, [Segment(0.0, step=1.0)])
    return exact.refined(on_grid, t, y, slope[:, ss.outputs.index(output)])


PEAK_CANDIDATES = 8  # the grid's largest local maxima refined for the peak
SETTLING_CANDIDATES = 64  # the last extrema near the band checked for settling


class ExactStep:
    """One output's exact response to a unit step at one input of a continuous closed loop:
    y(t) = c x(t) + d and y'(t) = c (A x(t) + b), x(t) from expm([[A, b], [0, 0]] t)."""

    def __init__(self, ss: StateSpace, source: str, output: str) -> None:
        k, j = ss.inputs.index(source), ss.outputs.index(output)
        n = ss.A.shape[0]
        self._augmented = np.zeros((n + 1, n + 1))
        self._augmented[:n, :n], self._augmented[:n, n] = ss.A, ss.B[:, k]
        self._A, self._b, self._c, self._d = ss.A, ss.B[:, k], ss.C[j], float(ss.D[j, k])

    def _state(self, time: float) -> np.ndarray:
        from scipy.linalg import expm  # on first use: the workbench's first paint loads no scipy

        return expm(self._augmented * time)[:-1, -1]

    def value(self, time: float) -> float:
        return float(self._c @ self._state(time)) + self._d

    def slope(self, time: float) -> float:
        return float(self._c @ (self._A @ self._state(time) + self._b))

    def _root(self, f, a: float, b: float) -> float:
        fa, fb = f(a), f(b)
        if fa == 0 or fb == 0 or fa * fb > 0:  # at a sample, or no sign change left: the sample nearer 0
            return a if abs(fa) <= abs(fb) else b
        from scipy.optimize import brentq  # on first use, as expm

        return float(brentq(f, a, b, xtol=1e-15 * max(abs(a), abs(b), 1.0), rtol=4 * np.finfo(float).eps))

    def crossing(self, level: float, a: float, b: float) -> float:
        """Where y = ``level`` between a and b (a bracket)."""
        return self._root(lambda time: self.value(time) - level, a, b)

    def stationary(self, a: float, b: float) -> float:
        """Where y' = 0 between a and b (a bracket)."""
        return self._root(self.slope, a, b)

    def refined(self, grid: StepMeasures, t: np.ndarray, y: np.ndarray, dy: np.ndarray) -> StepMeasures:
        """``grid`` (the measures on the samples t, y; y' = dy there) refined on the exact response."""
        final = grid.final
        r = y / final

        def first(level: float) -> float | None:
            above = np.flatnonzero(r >= level)
            if above.size == 0:
                return None
            i = int(above[0])
            return float(t[0]) if i == 0 else self.crossing(level * final, t[i - 1], t[i])

        t10, t90 = first(0.1), first(0.9)
        peak_time, peak = self._peak(grid, t, r, dy)
        return replace(
            grid,
            rise_time=None if t10 is None or t90 is None else t90 - t10,
            delay_time=first(0.5),
            peak_time=peak_time,
            peak=peak,
            overshoot_percent=0.0 if peak_time is None else (peak / final - 1.0) * 100.0,
            settling_time=self._settling(grid, t, r, dy),
        )

    def _peak(self, grid: StepMeasures, t: np.ndarray, r: np.ndarray, dy: np.ndarray) -> tuple[float | None, float]:
        """The peak's time and value (the global rule): the largest of the grid's peak sample and its
        `PEAK_CANDIDATES` largest local maxima, each moved to where y' vanishes beside it."""
        if grid.peak_time is None:
            return None, grid.peak
        maxima = np.flatnonzero((dy[:-1] > 0) & (dy[1:] <= 0))
        candidates = maxima[np.argsort(-np.maximum(r[maxima], r[maxima + 1]))[:PEAK_CANDIDATES]]
        found = [(grid.peak_time, grid.peak)]
        for a in candidates:
            time = self.stationary(t[a], t[a + 1])
            found.append((time, self.value(time)))
        return max(found, key=lambda tv: tv[1] / grid.final)

    def _settling(self, grid: StepMeasures, t: np.ndarray, r: np.ndarray, dy: np.ndarray) -> float | None:
        """The last time |r - 1| = band: after the last sample outside (none: the grid's answer, t[0] or
        None), every extremum between samples that comes within a sample's change of the band checked,
        the last one outside the start."""
        outside = np.flatnonzero(np.abs(r - 1.0) > SETTLING_BAND)
        if outside.size == 0 or grid.settling_time is None:
            return grid.settling_time
        final, last = grid.final, int(outside[-1])
        reach = float(np.max(np.abs(np.diff(r[last:]))))
        turns = last + np.flatnonzero(np.sign(dy[last:-1]) * np.sign(dy[last + 1 :]) < 0)
        near = turns[np.maximum(np.abs(r[turns] - 1.0), np.abs(r[turns + 1] - 1.0)) > SETTLING_BAND - reach]
        start, value = float(t[last]), float(r[last])
        for a in near[::-1][:SETTLING_CANDIDATES]:  # the last extremum outside, if any
            time = self.stationary(t[a], t[a + 1])
            if abs(self.value(time) / final - 1.0) > SETTLING_BAND:
                start, value, last = time, self.value(time) / final, int(a)
                break
        level = (1.0 + SETTLING_BAND if value > 1.0 else 1.0 - SETTLING_BAND) * final
        return self.crossing(level, start, float(t[last + 1]))

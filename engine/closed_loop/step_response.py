"""A closed loop's step response and its classical measures, as the workbench's step plot
and the design report show it.

The engineer chooses the input stepped and the output shown (`StepSetup`); by
default the first input and the output named y, c or x1.  The horizon, unless
given, comes from the closed-loop poles (8 time constants of the slowest, 5 of the
fastest unstable).  The measures: rise time (10-90 %), overshoot, settling band
(+-5 %) and settling time (`time_response.step_measures`), from the DC gain's final
value (none when the response has no settled final value to measure from).

A sampled loop (its realization in w, `StateSpace.sample_time`) responds at its samples
t = k T: its realization taken to z (w = (z - 1)/(z + 1)) and stepped sample by sample; the response is drawn as a staircase and measured at the
samples, over a horizon from the poles' radii (8 time constants -T/ln|z| of the slowest).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from engine.closed_loop.time_response import Segment, StepMeasures, final_value, simulate, step_measures
from engine.errors import EngineError
from engine.loop.realization import StateSpace, realize
from engine.model.bilinear import s_of_z, z_of_w
from engine.model.network import Network

SAMPLES = 400
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
    segments = [Segment(0.0, step=1.0)]
    try:
        y = simulate(ss, source, t, segments)[:, ss.outputs.index(output)]
    except EngineError:
        return None
    return StepResponse(t.tolist(), y.tolist(), f"{output} (step at {source})", _measures(ss, source, output, t, y))


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
    return step_measures(t, y, final, band=SETTLING_BAND)

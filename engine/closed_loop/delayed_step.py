"""The step response of a continuous loop with time delays exp(-tau s), simulated, and its measures
with the error each one carries.

The delays are opened (`engine.loop.realization.realize_opened`: the rational rest a state space, each
delay's input an output of it and its output an input) and the loop stepped on a uniform grid whose
step h divides every delay (`common_step`), each delay a ring of past samples, the rest integrated
exactly for inputs linear between samples (`time_response.simulate_delayed`): the error is O(h^2).  It
is run twice, on h and h/2: the finer run is shown, and the difference of the two (divided by 3, the
O(h^2) rule of Richardson) is the estimate of each measure's error and of the curve's, so each measure
is given to the digits that estimate supports (`digits_supported`).

Stability, the horizon and the final value: the free recurrence of the same scheme
(`time_response.delay_recurrence`) has eigenvalues z ~ exp(lambda h) of the loop's characteristic roots
lambda; the rightmost one, log(z)/h, decides: stable (Re < 0) -> the final value is the DC gain of the
loop with every delay 1 and the horizon 8 time constants of that root, else y at the horizon and 5 of
its e-foldings (at least 4 of the longest delay either way).  When the recurrence would be too large
(a delay `ROOT_STATES` times the common step) the verdict is unknown: final value from the horizon.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from fractions import Fraction

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.time_response import (
    StepMeasures,
    dc_gain,
    delay_recurrence,
    simulate_delayed,
    step_measures,
)
from engine.errors import EngineError
from engine.loop.pole_zero import without_delays
from engine.loop.realization import OpenedDelays, StateSpace, realize, realize_opened
from engine.model.network import Network

SAMPLES = 2000  # the coarse run's samples over the horizon, at least (the fine run twice as many)
PER_PERIOD = 16  # samples per period of the rightmost root's oscillation, at least
MOST_SAMPLES = 400_000  # the fine run's samples at most (then the horizon is cut and a note says so)
ROOT_STATES = 600  # the free recurrence's size at most (the stability verdict and the horizon)
COMMON_DENOMINATOR = 64  # delays whose ratios need a larger denominator have no common step
MAX_HORIZON = 1e4
SHOWN = 20_000  # the curve's points at most (thinned evenly; the measures read every sample)
BAND = 0.05
MEASURES = ("rise_time", "delay_time", "peak_time", "peak", "overshoot_percent", "settling_time")


@dataclass(frozen=True)
class DelayedStep:
    """One output's simulated step response (the fine run), its measures (None: no settled final value),
    each measure's estimated absolute error (inf: the two runs disagree on whether it exists), the curve's,
    the grid's step, the rightmost characteristic root's estimate, and how it was obtained."""

    t: NDArray
    y: NDArray
    measures: StepMeasures | None
    errors: dict[str, float]
    curve_error: float
    step: float
    rightmost: complex | None
    how: str
    note: str | None = None


def common_step(taus: tuple[float, ...]) -> float:
    """The longest step d of which every delay is a whole multiple (to 1e-9 relative): the shortest delay
    divided by the denominators' least common multiple of the ratios tau_k / tau_min (each at most
    `COMMON_DENOMINATOR`); an `EngineError` when there is none."""
    shortest = min(taus)
    lcm = 1
    for tau in taus:
        ratio = Fraction(tau / shortest).limit_denominator(COMMON_DENOMINATOR)
        if abs(float(ratio) * shortest - tau) > 1e-9 * tau:
            raise EngineError(
                f"the delays {', '.join(f'{v:g}' for v in taus)} s have no common step (their ratios are not "
                f"fractions with denominators up to {COMMON_DENOMINATOR}): no step response is simulated"
            )
        lcm = math.lcm(lcm, ratio.denominator)
    return shortest / lcm


def rightmost_root(ss: StateSpace, delays: list[tuple[int, int, int]], step: float) -> complex | None:
    """The rightmost characteristic root's estimate log(z)/step (z the free recurrence's eigenvalue of
    largest modulus), None when it cannot be computed."""
    try:
        z = np.linalg.eigvals(delay_recurrence(ss, delays, step))
    except (np.linalg.LinAlgError, ValueError):
        return None
    z = z[np.isfinite(z)]
    if z.size == 0 or np.max(np.abs(z)) == 0:
        return None
    top = z[np.argmax(np.abs(z))]
    return complex(np.log(abs(top)) / step, abs(np.angle(top)) / step)


def delayed_step(
    network: Network, params: Mapping[str, float], source: str, output: str, end: float | None = None
) -> DelayedStep:
    """The step response of ``output`` to a unit step at ``source`` of a continuous loop with delays, over
    ``end`` seconds (else the horizon from its rightmost root); an `EngineError` when it has no
    realization with its delays opened or its delays no common step."""
    opened = realize_opened(network, params)
    ss, taus = opened.ss, opened.taus
    if not taus:
        raise EngineError("the loop has no delay")
    base = common_step(taus)
    n = ss.A.shape[0]
    per_base = max(1, min(32, math.floor(base * (ROOT_STATES - n) / sum(taus))))
    lags_root = [round(tau / base) * per_base for tau in taus]
    root = None
    if n + sum(lags_root) <= ROOT_STATES:
        root = rightmost_root(ss, _delays(opened, lags_root), base / per_base)
    stable = root is not None and root.real < 0
    longest = max(taus)
    if end is None:
        if root is None or root.real == 0:
            end = max(10.0, 10 * longest)
        else:
            end = max((8.0 if stable else 5.0) / abs(root.real), 4 * longest)
        end = min(end, MAX_HORIZON)
    wanted = max(base * SAMPLES / end, base * PER_PERIOD * (root.imag if root is not None else 0.0) / (2 * math.pi))
    m = max(1, math.ceil(wanted))
    note, cut = None, None
    if 2 * end * m / base > MOST_SAMPLES:
        m = max(1, math.floor(MOST_SAMPLES * base / (2 * end)))
        if 2 * end * m / base > MOST_SAMPLES:
            cut = MOST_SAMPLES * base / (2 * m)
            note = (
                f"simulated over {cut:.6g} s, not {end:.6g} s: a grid whose step divides the delays "
                f"({base:.6g} s) has at most {MOST_SAMPLES} samples; no measures on a response cut short"
            )
            end = cut
    runs = []
    for k in (1, 2):
        h = base / (m * k)
        count = math.floor(end / h + 1e-9) + 1
        runs.append((h, simulate_delayed(ss, source, _delays(opened, [round(tau / h) for tau in taus]), h, count)))
    j = ss.outputs.index(output)
    (h_c, coarse), (h_f, fine) = runs
    yc, yf = coarse.right[:, j], fine.right[::2, j]
    size = min(yc.size, yf.size)
    with np.errstate(all="ignore"):
        curve_error = float(np.max(np.abs(yc[:size] - yf[:size]), initial=0.0)) / 3.0
    if not (coarse.complete and fine.complete):
        note = "the response leaves the floating-point range within the horizon: shown until it does"
    final, final_from = _final(network, params, source, output, stable, fine.y[:, j])
    measures, errors = None, {}
    if final_from == "dc_gain" and final != 0 and math.isfinite(final) and cut is None:
        measures = _measures(fine.t, fine.y[:, j], final, h_f)
        errors = measure_errors(_measures(coarse.t, coarse.y[:, j], final, h_c), measures, 3.0)
    largest = float(np.max(np.abs(fine.y[:, j]), initial=0.0)) or 1.0
    steps = ", ".join(f"{round(tau / h_f)}" for tau in taus)
    how = (
        f"simulated with the delay{'s' if len(taus) > 1 else ''} on a grid of {h_f:.3g} s "
        f"({steps} steps a delay, first-order hold), checked on one of {h_c:.3g} s: "
        f"the curve's error about {curve_error:.1g} ({curve_error / largest:.1g} of its largest value)"
    )
    if root is not None:
        how += f"; rightmost characteristic root about {root.real:.3g} +- {root.imag:.3g}j"
    shown = np.arange(fine.t.size)
    if shown.size > SHOWN:  # the curve thinned for drawing (the measures read every sample)
        shown = np.unique(np.concatenate([shown[:: math.ceil(shown.size / SHOWN)], shown[-1:]]))
    return DelayedStep(fine.t[shown], fine.y[shown, j], measures, errors, curve_error, h_f, root, how, note)


def measure_errors(coarse: StepMeasures | None, fine: StepMeasures | None, divisor: float) -> dict[str, float]:
    """Each measure's estimated error: its difference between a coarse and a fine estimate over
    ``divisor`` (3: Richardson's rule for O(h^2); 1: two estimates of no known order), at least 4 ulp of the
    fine one; inf where only one of them has it (or there is no coarse estimate)."""
    errors: dict[str, float] = {}
    for name in MEASURES:
        a, b = getattr(coarse, name, None), getattr(fine, name, None)
        if a is None and b is None:
            continue
        errors[name] = (
            math.inf if a is None or b is None else max(abs(a - b) / divisor, 4 * np.finfo(float).eps * abs(b))
        )
    return errors


def _delays(opened: OpenedDelays, lags: list[int]) -> list[tuple[int, int, int]]:
    return list(zip(lags, opened.delay_inputs, opened.delay_outputs))


def _final(
    network: Network, params: Mapping[str, float], source: str, output: str, stable: bool, y: NDArray
) -> tuple[float, str]:
    """The DC gain of the loop with every delay 1 (when the loop is stable), else y at the horizon."""
    finite = y[np.isfinite(y)]
    last = float(finite[-1]) if finite.size else math.nan
    if not stable:
        return last, "horizon"
    try:
        rational = realize(without_delays(network), params)
        gain = float(dc_gain(rational, source)[rational.outputs.index(output)])
    except (EngineError, np.linalg.LinAlgError):
        return last, "horizon"
    return gain, "dc_gain"


def _measures(t: NDArray, y: NDArray, final: float, h: float) -> StepMeasures:
    """`step_measures` on the samples (crossings interpolated linearly: O(h^2)), the peak moved to the
    vertex of the parabola through the largest sample and its neighbours (O(h^2) in time)."""
    found = step_measures(t, y, final, band=BAND)
    if found.peak_time is None:
        return found
    r = y / final
    i = int(np.argmax(r))
    if 0 < i < y.size - 1 and t[i - 1] < t[i] < t[i + 1]:
        a, b, c = y[i - 1], y[i], y[i + 1]
        curve = a - 2 * b + c
        if curve != 0:
            shift = float(np.clip(0.5 * (a - c) / curve, -1.0, 1.0))
            peak = b - 0.25 * (a - c) * shift
            if peak / final >= r[i]:
                t_peak = float(t[i] + shift * (t[i + 1] - t[i]))
                return _replaced(found, peak_time=t_peak, peak=float(peak), overshoot_percent=(peak / final - 1) * 100)
    return found


def _replaced(m: StepMeasures, **changes: float) -> StepMeasures:
    values = {f.name: getattr(m, f.name) for f in fields(m)}
    values.update(changes)
    return StepMeasures(**values)


def digits_supported(value: float, error: float, most: int = 6) -> int:
    """The significant digits of ``value`` that an absolute ``error`` leaves (1 to ``most``): the last one
    printed a unit 10^k no finer than the error (4e-6 -> 1e-5)."""
    if not (math.isfinite(error) and math.isfinite(value)) or value == 0:
        return 1 if not math.isfinite(error) else most
    if error <= 0:
        return most
    return int(min(most, max(1, math.floor(math.log10(abs(value))) - math.ceil(math.log10(error)) + 1)))

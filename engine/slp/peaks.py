"""slp's rows of the closed-loop measures (`engine.margins.peak_measures`): the
balanced disk margin, Ms, Mt and the delay margin, one row per band, and
their analytic partials.

Values: the refined peak over the row's band (every peak row of a band in
one search); a rational condition whose closed loop is unstable has a disk
margin of 0 and Ms = Mt = inf (absent from the LP, unmet); the delay margin is the smallest of the gain crossovers in
the band (inf with none: any delay is tolerated).

Partials ("analytic"), from the engine's sensitivities dGH/dx at the row's
frequency w*:
  Ms, Mt: d|f|/dx = Re(conj(f) df/dL dGH/dx)/|f| at fixed w* (f = S or T; at
      an interior maximum the frequency's move adds nothing, at a band edge
      the frequency is fixed);
  disk margin alpha = 1/|S - 1/2|: -d|f|/dx / |f|^2;
  delay margin phase/w at a crossover moving with x (`delay_partial`).
A peak at w = 0 or at infinity (a limit), a disk margin of 0 (unstable) or a
tabulated loop fall back to slp's forward differences.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from numpy.typing import NDArray

from engine.design.problem import Condition
from engine.loop.design import closed_loop_realization
from engine.loop.realization import StateSpace
from engine.loop.responses import LoopModel
from engine.margins.peak_measures import (
    CLOSED_LOOP_MEASURES,
    PEAK_MEASURES,
    band_delay,
    band_peaks,
    delay_partial,
    peak_partial,
    stable_realization,
)
from engine.margins.search import Band, Margins


def closed_loop_values(
    condition: Condition,
    params: dict[str, float],
    model: LoopModel,
    found: Margins,
    specs: Sequence,
    ss: StateSpace | None,
) -> dict[int, tuple[float, float]]:
    """index -> (value, frequency) of every closed-loop row among ``specs`` (one condition's)."""
    out: dict[int, tuple[float, float]] = {}
    mine = [i for i, s in enumerate(specs) if s.kind in CLOSED_LOOP_MEASURES]
    stable = None
    if condition.network.rational and mine:
        ss = ss if ss is not None else closed_loop_realization(condition.network, condition.break_at, params)
        stable = stable_realization(ss.A)
    bands: dict[tuple[float, float], list[int]] = {}
    for i in mine:
        if specs[i].kind == "delay_margin":
            out[i] = band_delay(found, Band(specs[i].low, specs[i].high), stable)
        else:
            bands.setdefault((specs[i].low, specs[i].high), []).append(i)
    for (low, high), rows in bands.items():
        peaks = band_peaks(model, [specs[i].kind for i in rows], Band(low, high), stable)
        for i, (value, frequency, _) in zip(rows, peaks):
            out[i] = (value, frequency)
    return out


def closed_loop_row(kind: str, gh: complex, gh_x: NDArray, gh_w: complex, omega: float, value: float) -> NDArray:
    """d(measure)/d(parameters) of a closed-loop row at its frequency (the module docstring)."""
    if kind == "delay_margin":
        return delay_partial(gh, gh_x, gh_w, omega, value)
    return peak_partial(kind, gh, gh_x)


def analytic_row(kind: str, value: float, frequency: float) -> bool:
    """A row with analytic partials: a closed-loop measure at a finite positive frequency
    (a disk margin of 0, an unstable loop's, is not differentiable)."""
    if kind not in CLOSED_LOOP_MEASURES or not (math.isfinite(value) and math.isfinite(frequency)):
        return False
    return frequency > 0 and (kind not in PEAK_MEASURES or value > 0)

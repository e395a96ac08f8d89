"""One call for the whole open-loop picture of a network: margins, crossover,
delay margin, modal peaks, closed-loop poles and the stability verdict."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .blocks import ExpressionTransfer
from .errors import EngineError
from .loops import LoopModel, loop_model
from .margins import Band, Margins, margins
from .network import Block, Junction, Network, block_diagram
from .realization import Pole, poles, realize, stability


@dataclass(frozen=True)
class ModalPeak:
    """A local maximum of |GH| in a band: frequency (rad/s), level (dB), phase (deg)."""

    frequency: float
    magnitude_db: float
    phase_deg: float


@dataclass(frozen=True)
class LoopAnalysis:
    margins: Margins
    closed_loop_poles: tuple[Pole, ...] | None
    verdict: str  # "stable", "unstable", "marginally stable" or "unknown"
    modal_peaks: tuple[ModalPeak, ...]
    notes: tuple[str, ...]


def unity_feedback(expressions: Sequence[str], variable: str = "s") -> Network:
    """r -> (+) -> e -> product of the expressions -> y, with e = r - y; break at 'e'."""
    if not expressions:
        raise EngineError("give at least one transfer function")
    blocks, previous = [], "e"
    for k, text in enumerate(expressions):
        out = "y" if k == len(expressions) - 1 else f"x{k + 1}"
        blocks.append(Block(f"L{k + 1}", previous, out, ExpressionTransfer(text, variable)))
        previous = out
    return block_diagram(blocks, [Junction("sum", "e", ((1.0, "r"), (-1.0, "y")))], ["r"], variable)


def modal_peaks(model: LoopModel, bands: Sequence[Band]) -> tuple[ModalPeak, ...]:
    """Local maxima of |GH| inside each band, with the phase there."""
    found = margins(model, attenuation_above=0.0).attenuation
    out = []
    for m in found:
        if any(b.contains(m.frequency) for b in bands):
            out.append(ModalPeak(m.frequency, float(20 * np.log10(abs(m.gh))), float(np.degrees(np.angle(m.gh)))))
    return tuple(out)


def analyze(network: Network, break_at: str, omega: ArrayLike, params: Mapping[str, float],
            peak_bands: Sequence[Band] = ()) -> LoopAnalysis:
    """Margins of the loop broken at ``break_at``, and the closed-loop poles when rational."""
    model = loop_model(network, break_at, omega, params)
    result = margins(model)
    notes = list(result.notes)
    pole_list: tuple[Pole, ...] | None = None
    verdict = "unknown"
    if network.rational:
        pole_list = tuple(poles(realize(network, params)))
        verdict = stability(list(pole_list))
    else:
        notes.append("closed-loop poles need a rational model (no tables, no delays)")
    return LoopAnalysis(result, pole_list, verdict, modal_peaks(model, peak_bands), tuple(notes))


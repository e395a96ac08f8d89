"""A loop's resonances: the lightly damped pole pairs of its fixed blocks (the plant's
bending modes, a sensor's filter), exact from each block's pole-zero form (a state
space's from its realization), where a designer places a notch."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from engine.errors import EngineError
from engine.model.blocks import block_pole_zero
from engine.model.network import Network

LIGHT = 0.3  # a pole pair damped less than this is a resonance


@dataclass(frozen=True)
class Resonance:
    """A lightly damped pole pair: its natural frequency (rad/s), damping and block."""

    frequency: float
    damping: float
    block: str

    @property
    def text(self) -> str:
        return f"{self.frequency:.6g} rad/s, zeta {self.damping:.4g} ({self.block})"


def resonances(network: Network, params: Mapping[str, float]) -> list[Resonance]:
    """The pole pairs damped less than LIGHT of every block without parameters, lowest
    frequency first, each once (blocks that share a mode, as a matrix plant's do, list it
    once)."""
    found: dict[tuple[float, float], Resonance] = {}
    for entry in network.entries:
        transfer = entry.transfer
        if not transfer.rational_form or transfer.parameters:
            continue
        try:
            poles = block_pole_zero(transfer, params).poles
        except EngineError:
            continue
        for p in poles:
            w = abs(p)
            if p.imag > 0 and 0 <= -p.real / w < LIGHT:  # stable and light: an unstable pair is no notch's
                key = (round(w, 9), round(-p.real / w, 9))
                found.setdefault(key, Resonance(float(w), float(-p.real / w), entry.label))
    return sorted(found.values(), key=lambda r: r.frequency)

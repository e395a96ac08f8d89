"""The margins' values: one `Margin`, every margin of a loop (`Margins`),
frequency bands, and the distance and classical forms of a margin found at
a frequency (`margins_of`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class Margin:
    """One margin: kind G, P, S or A; its frequency (rad/s) and distance value."""

    kind: str
    frequency: float
    value: float
    gh: complex
    gain_db: float | None = None
    phase_deg: float | None = None
    delay: float | None = None


@dataclass(frozen=True)
class Margins:
    """Every margin of one loop, sorted by frequency within each kind."""

    gain: tuple[Margin, ...]
    phase: tuple[Margin, ...]
    stability: tuple[Margin, ...]
    attenuation: tuple[Margin, ...]
    method: str  # "refined", "fitted" or "grid"
    notes: tuple[str, ...] = field(default=())
    residual: float | None = None  # "fitted": the fit's relative residual on the table

    @property
    def label(self) -> str:
        """How the margins were obtained: 'refined', 'fitted (residual 2.1e-04)' or 'grid'."""
        return f"fitted (residual {self.residual:.1e})" if self.method == "fitted" else self.method

    @property
    def crossover_frequency(self) -> float | None:
        """Gain crossover of the phase margin nearest 0 deg (python-control's wc)."""
        if not self.phase:
            return None
        return min(self.phase, key=lambda m: abs(m.phase_deg)).frequency

    @property
    def delay_margin(self) -> float | None:
        """Smallest added delay that puts a gain crossover on -1 (s); None with no crossover."""
        delays = [m.delay for m in self.phase if m.delay is not None]
        return min(delays) if delays else None

    def all(self) -> tuple[Margin, ...]:
        return self.gain + self.phase + self.stability + self.attenuation


@dataclass(frozen=True)
class Band:
    """A frequency band [low, high] in rad/s (high may be inf)."""

    low: float = 0.0
    high: float = float("inf")

    def contains(self, w: float) -> bool:
        return self.low <= w <= self.high


def single_margin(kind: str, w: float, gh: complex) -> Margin:
    """A margin with its distance value and, for G and P, the classical forms."""
    return margins_of(kind, np.array([w], dtype=float), np.array([gh], dtype=complex))[0]


def margins_of(kind: str, w: NDArray, gh: NDArray) -> list[Margin]:
    """Margins of one kind at frequencies ``w`` where the loop is ``gh``:
    distance values and, for G and P, the classical forms (dB; degrees
    wrapped to (-180, 180] and the delay margin)."""
    with np.errstate(all="ignore"):
        magnitude, distance = np.abs(gh), np.abs(1.0 + gh)
        if kind == "G":
            db = np.where(magnitude > 0, -20.0 * np.log10(magnitude), np.inf)
            return [
                Margin("G", f, d, g, gain_db=x)
                for f, d, g, x in zip(w.tolist(), distance.tolist(), gh.tolist(), db.tolist())
            ]
        if kind == "P":
            phase = 180.0 + np.degrees(np.arctan2(gh.imag, gh.real))
            phase = np.where(phase > 180.0, phase - 360.0, phase)
            delay = np.radians(phase) % (2 * np.pi) / w
            return [
                Margin("P", f, d, g, phase_deg=x, delay=t if f > 0 else None)
                for f, d, g, x, t in zip(w.tolist(), distance.tolist(), gh.tolist(), phase.tolist(), delay.tolist())
            ]
    values = distance if kind == "S" else magnitude
    return [Margin(kind, f, v, g) for f, v, g in zip(w.tolist(), values.tolist(), gh.tolist())]

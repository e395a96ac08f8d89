"""The margins' values: one `Margin`, every margin of a loop (`Margins`),
frequency bands, and the distance and classical forms of a margin found at
a frequency (`margins_of`)."""

from __future__ import annotations

import math
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
    crossovers_beyond: float | None = None  # a delay loop searched up to here, |GH| >= 1: the delay margin is not known
    families: tuple[Family, ...] = ()  # a delay's periodic families of margins (outputs list a few of each)

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
        """Smallest added delay that puts a gain crossover on -1 (s); None with no crossover;
        NaN when crossovers may lie beyond the search (`crossovers_beyond`): not known."""
        if self.crossovers_beyond is not None:
            return math.nan
        delays = [m.delay for m in self.phase if m.delay is not None]
        return min(delays) if delays else None

    def listed(self, kind: str) -> tuple[Margin, ...]:
        """The gain ("G") or stability ("S") margins an output lists: a periodic family's
        few (`Family.listed`, the count in its summary), else all."""
        found = self.gain if kind == "G" else self.stability
        family = next((f for f in self.families if f.kind == kind), None)
        return found if family is None else family.listed(found)

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
    forms = margin_forms(kind, w, gh)
    value = forms["value"].tolist()
    if kind == "G":
        return [
            Margin("G", f, d, g, gain_db=x)
            for f, d, g, x in zip(w.tolist(), value, gh.tolist(), forms["gain_db"].tolist())
        ]
    if kind == "P":
        phase, delay = forms["phase_deg"].tolist(), forms["delay"].tolist()
        return [
            Margin("P", f, d, g, phase_deg=x, delay=t if f > 0 else None)
            for f, d, g, x, t in zip(w.tolist(), value, gh.tolist(), phase, delay)
        ]
    return [Margin(kind, f, v, g) for f, v, g in zip(w.tolist(), value, gh.tolist())]


def margin_forms(kind: str, w: NDArray, gh: NDArray) -> dict[str, NDArray]:
    """The numbers of `margins_of`'s margins as arrays of the shape of ``w`` and ``gh`` (any shape):
    ``value`` (|1 + GH|, |GH| for A) and, for G, ``gain_db``, for P, ``phase_deg`` and ``delay``."""
    with np.errstate(all="ignore"):
        magnitude, distance = np.abs(gh), np.abs(1.0 + gh)
        if kind == "G":
            return {"value": distance, "gain_db": np.where(magnitude > 0, -20.0 * np.log10(magnitude), np.inf)}
        if kind == "P":
            phase = 180.0 + np.degrees(np.arctan2(gh.imag, gh.real))
            phase = np.where(phase > 180.0, phase - 360.0, phase)
            return {"value": distance, "phase_deg": phase, "delay": np.radians(phase) % (2 * np.pi) / w}
    return {"value": distance if kind == "S" else magnitude}


FAMILY = 40  # more margins of one kind than this in a delay loop are a periodic family
FAMILY_LOWEST, FAMILY_NEAREST = 10, 5  # of a family, listed: the lowest in frequency and the nearest -1


@dataclass(frozen=True)
class Family:
    """A delay's periodic family of margins of one kind (exp(-s): a gain and a stability margin
    every 2 pi rad/s, 159 of each up to 1000 rad/s): how many, from where to where, the period
    2 pi/delay (rad/s), and which an output lists (`listed`)."""

    kind: str
    count: int
    low: float
    high: float
    period: float

    def listed(self, found: tuple[Margin, ...]) -> tuple[Margin, ...]:
        """The `FAMILY_LOWEST` lowest and the `FAMILY_NEAREST` nearest -1 (smallest |1 + GH|)."""
        lowest = sorted(found, key=lambda m: m.frequency)[:FAMILY_LOWEST]
        nearest = sorted(found, key=lambda m: m.value)[:FAMILY_NEAREST]
        return tuple(sorted({id(m): m for m in lowest + nearest}.values(), key=lambda m: m.frequency))

    @property
    def summary(self) -> str:
        name = {"G": "gain", "S": "stability"}[self.kind]
        return (
            f"{self.count} {name} margins from {self.low:.6g} to {self.high:.6g} rad/s, a periodic family (the delay "
            f"turns the phase once every {self.period:.6g} rad/s): the {FAMILY_LOWEST} lowest and the "
            f"{FAMILY_NEAREST} nearest -1 are listed"
        )


def family(kind: str, found: list[Margin], delay: float) -> Family | None:
    """The family of ``found`` when a delay makes one (more than `FAMILY` margins)."""
    if len(found) <= FAMILY or not delay > 0:
        return None
    frequencies = [m.frequency for m in found]
    return Family(kind, len(found), min(frequencies), max(frequencies), 2.0 * math.pi / delay)

"""The SISO disk margin of a loop L(j omega) (Seiler, Packard, Gahinet 2020,
"An introduction to disk margins"; the formulas of python-control's
`disk_margins`).

For a skew sigma (0: balanced, 1: the disk of S, -1: the disk of T)

    alpha = 1 / max_omega |S + (sigma - 1)/2|,   S = 1/(1 + L),

and the loop stays stable for every simultaneous gain and phase change f in
the disk D(alpha, sigma) = {(1 + (1 - sigma)/2 d)/(1 - (1 + sigma)/2 d):
|d| < alpha}.  Its real-axis ends are the guaranteed gain factors

    gamma_min = (1 - alpha (1 - sigma)/2) / (1 + alpha (1 + sigma)/2)
    gamma_max = (1 + alpha (1 - sigma)/2) / (1 - alpha (1 + sigma)/2)

and where it meets the unit circle the guaranteed phase margin
acos((1 + gamma_min gamma_max)/(gamma_min + gamma_max)).  The maximum is
refined to an exact extremum by `engine.margins.peaks.refined_peaks`, not
taken on a grid.  An unstable closed loop has no disk margin: alpha = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from numpy.typing import NDArray

from engine.errors import EngineError
from engine.loop.responses import LoopModel
from engine.margins.peaks import Peak, Transform, refined_peaks, sensitivity
from engine.margins.search import Band


class GuaranteedGains:
    """The gain factors a disk guarantees (``gain_low`` <= 1 <= ``gain_high``, inf when unbounded)
    in dB: one disk margin's (`DiskMargin`) or every loop's at once (`engine.multiloop.disk`)."""

    gain_low: float
    gain_high: float

    @property
    def gain_low_db(self) -> float:
        """The gain decrease tolerated, in dB (<= 0; -inf when down to 0)."""
        return 20.0 * math.log10(self.gain_low) if self.gain_low > 0 else -math.inf

    @property
    def gain_high_db(self) -> float:
        """The gain increase tolerated, in dB (>= 0; inf when unbounded)."""
        return 20.0 * math.log10(self.gain_high) if math.isfinite(self.gain_high) else math.inf

    @property
    def gain_db(self) -> float:
        """python-control's DGM: the smaller of both in dB, 20 log10 min(1/gamma_min, gamma_max)."""
        return min(-self.gain_low_db, self.gain_high_db)


@dataclass(frozen=True)
class DiskMargin(GuaranteedGains):
    """A disk margin: alpha, its skew, the guaranteed gain factors (low <= 1 <= high,
    high inf when unbounded), phase margin (deg), the worst disk's frequency."""

    alpha: float
    skew: float
    gain_low: float
    gain_high: float
    phase_deg: float
    frequency: float
    method: str = "refined"
    notes: tuple[str, ...] = field(default=())


def disk_transform(skew: float = 0.0) -> Transform:
    """f = S + (skew - 1)/2 and df/domega: the disk margin is 1/max |f|."""
    shift = 0.5 * (skew - 1.0)

    def f(w: NDArray, gh: NDArray, dgh: NDArray) -> tuple[NDArray, NDArray]:
        s, ds = sensitivity(w, gh, dgh)
        return s + shift, ds

    f.moebius = (0.5 * (1.0 + skew), shift)  # S + (skew - 1)/2 = ((1 + skew)/2 + (skew - 1)/2 GH)/(1 + GH)
    return f


def check_skew(skew: float) -> float:
    """The skew as a float, or an `EngineError` when it is not finite."""
    try:
        value = float(skew)
    except (TypeError, ValueError):
        raise EngineError(f"a disk margin's skew must be a number, not {skew!r}") from None
    if not math.isfinite(value):
        raise EngineError(f"a disk margin's skew must be finite, not {skew!r}")
    return value


def disk_margin(loop: LoopModel, skew: float = 0.0, stable: bool | None = None, band: Band = Band()) -> DiskMargin:
    """The disk margin of ``loop`` for ``skew``, its peak refined (module docstring).

    ``stable``: whether the closed loop is stable (False: alpha = 0; None:
    unknown, and a note says the margin assumes it)."""
    skew = check_skew(skew)
    if stable is False:
        return from_peak(None, skew, stable)
    return from_peak(refined_peaks(loop, [disk_transform(skew)], band)[0], skew, stable)


def from_peak(peak: Peak | None, skew: float, stable: bool | None = None) -> DiskMargin:
    """The disk margin given the refined peak of |S + (skew - 1)/2| (None or
    ``stable=False``: an unstable closed loop, alpha = 0)."""
    if peak is None or stable is False:
        note = "the closed loop is unstable: no disk margin (alpha = 0)"
        return DiskMargin(0.0, skew, 1.0, 1.0, 0.0, math.nan, "refined" if peak is None else peak.method, (note,))
    notes = peak.notes
    if stable is None:
        notes = notes + ("closed-loop stability unknown: the disk margin assumes a stable closed loop",)
    alpha = 1.0 / peak.value if peak.value > 0 else math.inf
    low, high, phase = disk_gain_phase(alpha, skew)
    return DiskMargin(alpha, skew, low, high, phase, peak.frequency, peak.method, notes)


def disk_gain_phase(alpha: float, skew: float) -> tuple[float, float, float]:
    """(gamma_min, gamma_max, phase margin in deg) of the disk D(alpha, skew).

    As python-control: gamma_max <= 0 (the disk is the outside of a circle)
    is an unbounded gain increase, inf; the phase is acos((1 + gmin gmax)/
    (gmin + gmax)), inf when that is not in (-1, 1).  gamma_min <= 0 (every
    gain decrease) reads 0.  Where gamma_max is exactly infinite the
    disk's edge is the line Re = gamma_min and the phase is acos(gamma_min)
    (python-control says 90 deg, which is that value at skew 0 only)."""
    if alpha == 0:
        return 1.0, 1.0, 0.0
    low = _ratio(1.0 - 0.5 * alpha * (1.0 - skew), 1.0 + 0.5 * alpha * (1.0 + skew))
    high_raw = _ratio(1.0 + 0.5 * alpha * (1.0 - skew), 1.0 - 0.5 * alpha * (1.0 + skew))
    # 1 - x, written without cancellation: a tiny alpha (exp(-s): 1.1e-15) leaves x = 1 - O(alpha^2),
    # which rounds to 1 (a phase 'inf' where it is 2 atan(alpha/2), about alpha rad, at skew 0)
    if math.isinf(high_raw):
        one_minus = 1.0 - low
    else:
        one_minus = _ratio((1.0 - low) * (high_raw - 1.0), low + high_raw)
    phase = math.degrees(2.0 * math.asin(math.sqrt(one_minus / 2.0))) if 0.0 <= one_minus < 2.0 else math.inf
    high = high_raw if 0 < high_raw < math.inf else math.inf
    return max(low, 0.0), high, phase


def _ratio(a: float, b: float) -> float:
    """a / b, +-inf (a's sign) where b is 0."""
    return a / b if b != 0 else math.copysign(math.inf, a)

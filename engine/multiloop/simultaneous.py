"""Simultaneous gain-only and phase-only margins of a square plant under unity feedback: every
loop's gain (or phase) changed at once and independently, f_i = 10^(g_i/20) (or e^{j phi_i}) at
input i, the closed loop's state matrix A - B F (I + D F)^-1 C.

Bracketed.  Lower (guaranteed): the multi-loop disk margin's disk holds the gains
gamma_min..gamma_max and the phases -phi..phi (`engine.multiloop.disk`), so every such
simultaneous change keeps the loop stable.  Upper (found): a destabilizing change, the smallest
max |g_i| (or |phi_i|) along rays t v from the origin over directions v (every corner of the
cube, every axis, the disk's worst perturbation), the first t where the closed loop's spectral
abscissa reaches 0 (a scan from the lower bound, then Brent), the best ray then refined by
Nelder and Mead on its direction (bounded: `RAY_POINTS`, `REFINE_STEPS`).  Status "tight" when
the two meet within `GAP`, else "bracket" (the disk is a sufficient condition only), or
"none found" when no change up to `MOST` destabilizes along the rays searched."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.multiloop.disk import GAP, MultiLoopDiskMargin
from engine.multiloop.plant import Plant

MOST = {"gain": 60.0, "phase": 180.0}  # dB, deg: the largest change searched
RAY_POINTS = 48  # abscissa evaluations of a ray's scan
REFINE_STEPS = 120  # Nelder-Mead evaluations refining the best direction


@dataclass(frozen=True)
class SimultaneousMargin:
    """``kind`` "gain" (dB) or "phase" (deg): every change with max |.| < ``lower`` keeps the loop
    stable; ``perturbation`` (one value a loop, max |.| = ``upper``) destabilizes it, a closed-loop
    pole at j ``frequency``."""

    kind: str
    lower: float
    upper: float
    perturbation: tuple[float, ...]
    frequency: float
    status: str


def _factors(kind: str, values: NDArray) -> NDArray:
    return 10.0 ** (values / 20.0) if kind == "gain" else np.exp(1j * np.radians(values))


def abscissa(plant: Plant, kind: str, values: NDArray) -> tuple[float, float]:
    """(largest real part, its |imaginary part|) of the closed loop's poles with the change ``values``."""
    f = _factors(kind, np.asarray(values, dtype=float))
    closing = np.eye(plant.loops) + plant.D * f[None, :]
    gain = f[:, None] * np.linalg.solve(closing, plant.C.astype(complex))  # F (I + D F)^-1 C
    poles = np.linalg.eigvals(plant.A - plant.B @ gain)
    k = int(np.argmax(poles.real))
    return float(poles[k].real), float(abs(poles[k].imag))


def _ray(plant: Plant, kind: str, v: NDArray, start: float) -> float:
    """The smallest t in [start, MOST] with the abscissa at t v >= 0 (inf when none on the scan)."""
    from scipy import optimize

    ts = np.geomspace(max(start, 1e-6), MOST[kind], RAY_POINTS)
    previous = start
    for t in ts:
        if abscissa(plant, kind, t * v)[0] >= 0:
            if previous == t or abscissa(plant, kind, previous * v)[0] >= 0:
                return float(t)
            return float(
                optimize.brentq(lambda x: abscissa(plant, kind, x * v)[0], previous, t, xtol=1e-14, rtol=1e-15)
            )
        previous = t
    return math.inf


def _directions(m: int, worst: NDArray | None) -> list[NDArray]:
    corners = [np.array(c, dtype=float) for c in itertools.product((-1.0, 1.0), repeat=m)]
    axes = [s * np.eye(m)[i] for i in range(m) for s in (-1.0, 1.0)]
    extra = [worst / np.abs(worst).max()] if worst is not None and np.abs(worst).max() > 0 else []
    return corners + axes + extra


def _refined(plant: Plant, kind: str, v: NDArray, best: float, start: float) -> tuple[float, NDArray]:
    """Nelder-Mead on the direction (normalized to max |v_i| = 1) from the best ray."""
    from scipy import optimize

    def f(x: NDArray) -> float:
        size = np.abs(x).max()
        return _ray(plant, kind, x / size, start) if size > 0 else math.inf

    found = optimize.minimize(f, v, method="Nelder-Mead", options={"maxfev": REFINE_STEPS, "xatol": 1e-10})
    if found.fun < best:
        return float(found.fun), found.x / np.abs(found.x).max()
    return best, v


def simultaneous(plant: Plant, kind: str, disk: MultiLoopDiskMargin) -> SimultaneousMargin:
    """The simultaneous ``kind`` ("gain" or "phase") margin, bracketed (module docstring)."""
    lower = (disk.gain_db if kind == "gain" else disk.phase_deg) if disk.status != "unstable" else 0.0
    lower = min(lower, MOST[kind]) if math.isfinite(lower) else MOST[kind]
    worst = _worst(kind, disk)
    rays = [(_ray(plant, kind, v, lower), v) for v in _directions(plant.loops, worst)]
    best, v = min(rays, key=lambda r: r[0])
    if not math.isfinite(best):
        return SimultaneousMargin(
            kind, lower, math.inf, (), math.nan, f"none found (up to {MOST[kind]:g} on every ray)"
        )
    best, v = _refined(plant, kind, v, best, lower)
    values = best * v
    frequency = abscissa(plant, kind, values)[1]
    status = "tight" if (best - lower) <= GAP * best else "bracket (the lower bound is the multi-loop disk's)"
    return SimultaneousMargin(kind, lower, best, tuple(float(x) for x in values), frequency, status)


def _worst(kind: str, disk: MultiLoopDiskMargin) -> NDArray | None:
    """The disk's destabilizing change as gains (dB) or phases (deg): a direction to try."""
    if not disk.delta:
        return None
    d = np.array(disk.delta)
    with np.errstate(all="ignore"):
        f = (1 + 0.5 * (1 - disk.skew) * d) / (1 - 0.5 * (1 + disk.skew) * d)
    out = 20.0 * np.log10(np.abs(f)) if kind == "gain" else np.degrees(np.angle(f))
    return out if np.all(np.isfinite(out)) else None

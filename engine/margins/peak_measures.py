"""The closed-loop measures a target can name beside the margins: the
balanced disk margin alpha (skew 0), Ms = max |S|, Mt = max |T|, and the
delay margin.  One module for their values over a band (the tableau and
slp), every local extremum (cip's rows) and their partials at a fixed
frequency (slp's LP rows, cip's direction).

Each peak measure is the peak of |f| for a transform f of the open loop L
(`engine.margins.peaks`): f = S = 1/(1 + L) for Ms, f = T = L S for Mt,
f = S - 1/2 for the disk margin, alpha = 1/max |f| (skew 0: a target has
no options to carry another skew).  With 1 + F = 1/f, each is a stability
margin min |1 + F| of a transformed loop F (F = L for Ms: 1/Ms is the
stability margin itself; F = 1/L for Mt; F = (1 + 3L)/(1 - L) for alpha),
so cip can push it as it pushes stability margins (`newton_point`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from engine.loop.responses import LoopModel
from engine.margins.detection_grid import detection_grid
from engine.margins.disk import disk_transform

# the peak search's own steps, reused to keep every local maximum, not only the largest
from engine.margins.peaks import (
    Peak,
    Transform,
    band_grid,
    complementary,
    fast_form_agrees,
    log_level,
    refined_maxima,
    refined_peaks,
    resolved_grid,
    sensitivity,
)
from engine.margins.search import Band, Margins
from engine.numerics.refinement import sign_changes

PEAK_MEASURES = ("disk_margin", "sensitivity_peak", "complementary_sensitivity_peak")
CLOSED_LOOP_MEASURES = PEAK_MEASURES + ("delay_margin",)
DISK_SKEW = 0.0  # the balanced disk margin: a target carries no skew


def transform(measure: str) -> Transform:
    """The f whose peak |f| a peak measure reads."""
    return {
        "disk_margin": disk_transform(DISK_SKEW),
        "sensitivity_peak": sensitivity,
        "complementary_sensitivity_peak": complementary,
    }[measure]


def loop_derivative(measure: str, gh: NDArray | complex) -> tuple[NDArray, NDArray]:
    """(f, df/dL) of a peak measure's transform at open-loop values ``gh``."""
    gh = np.asarray(gh, dtype=complex)
    with np.errstate(all="ignore"):
        s = 1.0 / (1.0 + gh)
        if measure == "complementary_sensitivity_peak":
            return gh * s, s * s
        shift = -0.5 if measure == "disk_margin" else 0.0
        return s + shift, -s * s


def band_peaks(
    loop: LoopModel, measures: Sequence[str], band: Band, stable: bool | None = None
) -> list[tuple[float, float, Peak]]:
    """(value, frequency, the refined peak) of each peak measure over ``band``, refined in one
    search.  An unstable closed loop (``stable`` False) has no disk margin (0) and no finite
    Ms or Mt (inf: S and T have poles in the right half-plane), at frequency NaN."""
    return peak_values(measures, refined_peaks(loop, [transform(m) for m in measures], band), stable)


def peak_values(
    measures: Sequence[str], found: Sequence[Peak], stable: bool | None = None
) -> list[tuple[float, float, Peak]]:
    """(value, frequency, the peak) of each peak measure from its transform's refined peak (`band_peaks`)."""
    out = []
    for measure, peak in zip(measures, found):
        value, frequency = peak_arrays(
            measure, np.array(peak.value), np.array(peak.frequency), np.array(stable is not False)
        )
        out.append((float(value), float(frequency), peak))
    return out


def peak_arrays(
    measure: str, values: NDArray, frequencies: NDArray, stable: NDArray[np.bool_]
) -> tuple[NDArray, NDArray]:
    """`peak_values` of one measure for many loops at once: (values, frequencies) from its
    transform's peaks |f| at ``frequencies`` and each loop's closed-loop stability (an unstable
    one has no disk margin, 0, and no finite Ms or Mt, inf, at frequency NaN; the disk margin is
    alpha = 1/max |f|, `engine.margins.disk.from_peak`)."""
    if measure == "disk_margin":
        with np.errstate(divide="ignore"):
            values = np.where(values > 0, 1.0 / np.where(values > 0, values, 1.0), math.inf)
    unstable = 0.0 if measure == "disk_margin" else math.inf
    return np.where(stable, values, unstable), np.where(stable, frequencies, math.nan)


def band_peak(loop: LoopModel, measure: str, band: Band, stable: bool | None = None) -> tuple[float, float, Peak]:
    """(value, frequency, the refined peak) of one peak measure over ``band`` (`band_peaks`)."""
    return band_peaks(loop, [measure], band, stable)[0]


def band_delay(found: Margins, band: Band, stable: bool | None = None) -> tuple[float, float]:
    """(the smallest delay margin of the gain crossovers in ``band``, its frequency);
    (inf, nan) with none there (any delay is tolerated, as python-control says); (0, nan)
    for an unstable closed loop (``stable`` False: already unstable, no delay is tolerated)."""
    if stable is False:
        return 0.0, math.nan
    delays = [m for m in found.phase if m.delay is not None and band.contains(m.frequency)]
    if not delays:
        return math.inf, math.nan
    worst = min(delays, key=lambda m: m.delay)
    return float(worst.delay), worst.frequency


def local_peaks(loop: LoopModel, measure: str, band: Band) -> tuple[tuple[float, float, complex], ...]:
    """(frequency, |f|, GH) of every interior local maximum of |f| inside ``band``:
    refined to 4 ulp as `engine.margins.peaks` refines the peak; on a tabulated
    loop (no evaluator) the grid's local maxima (report 000's SRMINS rule)."""
    f = transform(measure)
    if loop.evaluate is None:
        return _grid_peaks(loop.omega, loop.gh, f, band)
    found = _local_on(loop, f, band)
    check = [Peak(v, w) for w, v, _ in found]
    if loop.exact is not loop.evaluate and check and not fast_form_agrees(loop, [f], check):
        found = _local_on(loop.on_exact(), f, band)
    return found


def _local_on(loop: LoopModel, f: Transform, band: Band) -> tuple[tuple[float, float, complex], ...]:
    grid = detection_grid(loop)
    w, gh, dgh = band_grid(loop, grid.omega, grid.gh, grid.dgh, band)
    w, gh, dgh = resolved_grid(loop, [f], w, gh, dgh, [])
    at, _ = refined_maxima(loop, [f], w, [log_level(*f(w, gh, dgh))])
    at = np.sort(at[(at > band.low) & (at < band.high)])
    if at.size == 0:
        return ()
    g, dg = loop.evaluate(at)
    magnitude = np.abs(f(at, g, dg)[0])
    return tuple((float(a), float(v), complex(x)) for a, v, x in zip(at, magnitude, g) if math.isfinite(v))


def _grid_peaks(w: NDArray, gh: NDArray, f: Transform, band: Band) -> tuple[tuple[float, float, complex], ...]:
    magnitude = np.abs(f(w, gh, np.zeros_like(gh))[0])
    i = sign_changes(np.diff(magnitude**2), falling_only=True) + 1
    i = i[(w[i] >= band.low) & (w[i] <= band.high)]
    return tuple((float(w[k]), float(magnitude[k]), complex(gh[k])) for k in i)


def newton_point(measure: str, gh: complex) -> complex:
    """The point q = L + f/(df/dL) to push L from: 2 Re(conj(L - q) dL/dx) is a
    positive multiple of d|1 + F|^2/dx, the gradient of the measure's stability
    margin |1 + F| = 1/|f| at a fixed frequency (q = -1 for Ms)."""
    f, f_l = loop_derivative(measure, gh)
    return complex(gh + f / f_l)


def peak_partial(measure: str, gh: complex, gh_x: NDArray) -> NDArray:
    """d(value)/dx at a fixed frequency: d|f|/dx = Re(conj(f) df/dx)/|f| (at a
    stationary frequency the frequency's own move adds nothing), and for the
    disk margin alpha = 1/|f|: -d|f|/dx / |f|^2."""
    f, f_l = loop_derivative(measure, gh)
    f, f_l = complex(f), complex(f_l)
    magnitude = abs(f)
    d = np.real(np.conj(f) * f_l * np.asarray(gh_x)) / magnitude
    return -d / magnitude**2 if measure == "disk_margin" else d


def delay_partial(gh: complex, gh_x: NDArray, gh_w: complex, w: float, delay: float) -> NDArray:
    """d(delay margin)/dx at a gain crossover w moving with x: with L_x/L = a_x + j phi_x,
    w_x = -a_x/a_w, the phase margin's change phi_x + phi_w w_x, and delay = phase/w:
    d delay = (phi_x + phi_w w_x)/w - delay w_x / w."""
    l_x, l_w = np.asarray(gh_x) / gh, gh_w / gh
    w_x = -l_x.real / l_w.real
    return (l_x.imag + l_w.imag * w_x) / w - delay * w_x / w


def stable_realization(A: NDArray) -> bool:
    """Whether a closed loop's state matrix has every eigenvalue in the open left half-plane."""
    return True if A.size == 0 else bool(np.max(np.linalg.eigvals(A).real) < 0)

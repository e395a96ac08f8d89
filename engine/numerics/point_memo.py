"""The values of a fixed function of frequency already computed, looked up point by point.

A tabulated block's rational fit does not change with the design, yet every nudge asks it at
the same frequencies again: the table's own points (the fit's residual on the loop), the
detection grid and its subdivisions (`engine.margins.detection_grid`, built from corners
that mostly stay).  `PointMemo` keeps the last frequencies asked (sorted, at most
`MOST_POINTS`) with their values and computes only the ones it has not seen.  Each point's
value is the function's at that point alone (the fit's evaluation is row by row), so what
it returns is what the function returns at that point: the same to the last bit when the
function's arithmetic per point does not depend on the other points asked with it, and
otherwise within the rounding of the function's own vectorized arithmetic (a matrix
product's blocking may differ with the array's length: an ulp or so).  Thread-safe: the
workbench's workers share a fit."""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

MOST_POINTS = 20_000  # frequencies kept; past this the memo keeps only the last call's

Pair = tuple[NDArray[np.complex128], NDArray[np.complex128]]


class PointMemo:
    """Values and slopes of one function of frequency, by frequency (see the module docstring)."""

    def __init__(self) -> None:
        self._omega = np.zeros(0)
        self._value = np.zeros(0, dtype=complex)
        self._slope = np.zeros(0, dtype=complex)
        self._lock = threading.Lock()

    def values(self, omega: NDArray[np.float64], compute: Callable[[NDArray[np.float64]], Pair]) -> Pair:
        """``compute(omega)``, shaped like ``omega``, calling ``compute`` only on the finite
        frequencies not kept (each once, sorted)."""
        w = np.asarray(omega, dtype=float)
        flat = w.ravel()
        if not np.all(np.isfinite(flat)):
            return compute(w)
        with self._lock:
            known, value, slope = self._omega, self._value, self._slope
        at = np.minimum(np.searchsorted(known, flat), max(known.size - 1, 0))
        hit = known[at] == flat if known.size else np.zeros(flat.size, dtype=bool)
        out_value, out_slope = np.empty(flat.size, dtype=complex), np.empty(flat.size, dtype=complex)
        out_value[hit], out_slope[hit] = value[at[hit]], slope[at[hit]]
        if not hit.all():
            new = np.unique(flat[~hit])
            new_value, new_slope = compute(new)
            where = np.searchsorted(new, flat[~hit])
            out_value[~hit], out_slope[~hit] = new_value[where], new_slope[where]
            self._keep(known, value, slope, new, np.asarray(new_value), np.asarray(new_slope))
        return out_value.reshape(w.shape), out_slope.reshape(w.shape)

    def _keep(self, known, value, slope, new, new_value, new_slope) -> None:
        """Merge the new points into the kept ones (or keep the new alone past `MOST_POINTS`)."""
        if known.size + new.size <= MOST_POINTS:
            order = np.argsort(np.concatenate([known, new]), kind="stable")
            new, new_value, new_slope = (
                np.concatenate(pair)[order] for pair in ((known, new), (value, new_value), (slope, new_slope))
            )
        with self._lock:
            self._omega, self._value, self._slope = new, new_value, new_slope

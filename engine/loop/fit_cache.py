"""The last rational fits of tabulated loops, kept by the table's content.

One design's margins, Ms, Mt and disk margin all fit the same table
(`engine.margins.search.fitted_loop`); an AAA fit of a thousand points takes about
a second, so it is made once and shared (a fit is immutable).  Thread-safe:
the workbench's workers fit while the UI thread may ask too."""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

import numpy as np
from numpy.typing import NDArray

from engine.numerics.rational_fit import RationalFit, fit_response

KEPT = 16

_FITS: OrderedDict[bytes, RationalFit] = OrderedDict()
_LOCK = threading.Lock()


def cached_fit(omega: NDArray[np.float64], gh: NDArray[np.complex128]) -> RationalFit:
    """`fit_response(omega, gh)`, made once per table content (the last `KEPT` kept)."""
    w, f = np.ascontiguousarray(omega, dtype=float), np.ascontiguousarray(gh, dtype=complex)
    key = hashlib.blake2b(w.tobytes() + f.tobytes(), digest_size=20).digest()
    with _LOCK:
        if key in _FITS:
            _FITS.move_to_end(key)
            return _FITS[key]
    fit = fit_response(w, f)
    with _LOCK:
        _FITS[key] = fit
        while len(_FITS) > KEPT:
            _FITS.popitem(last=False)
    return fit

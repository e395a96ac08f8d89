"""The last rational fits of tabulated loops, kept by the table's content.

One design's margins, Ms, Mt and disk margin all fit the same table
(`engine.margins.search.fitted_loop`); an AAA fit of a thousand points takes about
a second, so it is made once and shared (a fit is immutable; so is a tabulated block's rational model,
`engine.loop.table_model`, which the step response asks for), kept in an
`engine.derived` store of the process (thread-safe: the workbench's workers fit
while the UI thread may ask too).  A fit is a form of the table's content, not of
one network: two conditions that tabulate one response share it."""

from __future__ import annotations

import hashlib

import numpy as np
from numpy.typing import NDArray

from engine.derived import Derived, Form
from engine.errors import EngineError
from engine.loop.table_model import TableModel, table_model
from engine.numerics.rational_fit import RationalFit, fit_response

KEPT = 16

FIT: Form[RationalFit] = Form("rational fit")  # asked with a hash of the table's content
MODEL: Form[TableModel | EngineError] = Form("table model")  # a tabulated block's (`table_model`), or its refusal
_FITS = Derived(KEPT)


def cached_fit(omega: NDArray[np.float64], gh: NDArray[np.complex128]) -> RationalFit:
    """`fit_response(omega, gh)`, made once per table content (the last `KEPT` used kept)."""
    w, f = np.ascontiguousarray(omega, dtype=float), np.ascontiguousarray(gh, dtype=complex)
    return _FITS.get(FIT, lambda: fit_response(w, f), content_key(w, f))


def cached_model(omega: NDArray[np.float64], response: NDArray[np.complex128], text: str) -> TableModel:
    """`table_model(omega, response, text)`, made once per table content (a refusal too: the same
    `EngineError` raised again)."""
    w, f = np.ascontiguousarray(omega, dtype=float), np.ascontiguousarray(response, dtype=complex)

    def made() -> TableModel | EngineError:
        try:
            return table_model(w, f, text)
        except EngineError as exc:
            return exc

    found = _FITS.get(MODEL, made, content_key(w, f), text)
    if isinstance(found, EngineError):
        raise found
    return found


def content_key(w: NDArray[np.float64], f: NDArray[np.complex128]) -> bytes:
    """A short digest of a response's frequencies and values (a key of forms made from them)."""
    return hashlib.blake2b(w.tobytes() + f.tobytes(), digest_size=20).digest()

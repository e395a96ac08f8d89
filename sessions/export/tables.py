"""A tabulated block in an export: its table as it is (python-control's and MATLAB's
``frd`` read it back exactly), or on request its AAA rational fit
(engine/numerics/rational_fit.py) with the residual stated.  Right-half-plane roots far
above the band (beyond a decade past its top) are dropped, the gain taking their
in-band value, and the residual restated on the table (zeros at +-2e5 rad/s and a gain
of 1e-19 were one export's); any other right-half-plane root outside the band (a pole
at +8e-7 rad/s) is an artefact the data cannot justify, and the fit is refused, as is
one that then misses the table by more than 1e-3: a peer tool would read margins off
them."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from engine.model.blocks import TabulatedTransfer
from engine.model.paired_product import PairedProduct
from engine.numerics.rational_fit import FAR_POLE, RationalFit, fit_response
from sessions.errors import SessionError

FIT_TOLERANCE = 1e-10  # relative residual asked of a table's fit (the residual reached is stated)
BAND_MARGIN = 10.0  # a root beyond a decade outside the table's frequencies is outside its band
ORIGIN = 1e-9  # relative to the band's bottom: a root this small is at the origin (a differentiator's 1e-16)
MAX_RESIDUAL = 1e-3  # relative: a fit that misses the table by more (its far roots dropped) is refused


def table_fields(transfer: TabulatedTransfer) -> dict:
    """A table's frequencies (rad/s, those above 0) and its response there."""
    table = transfer.table
    keep = table.omega > 0
    return {
        "kind": "table",
        "text": transfer.text,
        "omega": tuple(table.omega[keep].tolist()),
        "response": tuple(complex(v) for v in table.response[keep]),
    }


def fit_fields(transfer: TabulatedTransfer) -> dict:
    """A table's AAA fit as gain, zeros, poles and coefficients, with its residual and
    degree; a `SessionError` where it has right-half-plane roots outside the band."""
    table = transfer.table
    keep = table.omega > 0
    omega = table.omega[keep]
    fit = fit_response(omega, table.response[keep], tolerance=FIT_TOLERANCE)
    zeros, poles = _clean(fit_zeros(fit)), _clean(np.asarray(fit.poles))
    high = BAND_MARGIN * float(omega.max())
    zeros, poles = zeros[~_far_right(zeros, high)], poles[~_far_right(poles, high)]
    _refuse_artefacts(transfer.text, zeros, poles, float(omega.min()), float(omega.max()))
    w0 = float(np.sqrt(omega[0] * omega[-1]))
    shape = PairedProduct(1.0, zeros, poles)
    gain = float((fit(np.array([w0]))[0] / shape.terms(np.array([1j * w0])).value[0]).real)
    model = gain * shape.terms(1j * omega).value
    scale = np.maximum(np.abs(table.response[keep]), 1e-300)
    residual = float(np.max(np.abs(model - table.response[keep]) / scale))
    if not residual <= MAX_RESIDUAL:  # NaN too (a zero in the table)
        raise SessionError(
            f"--fit: the rational fit of {transfer.text} misses the table by {residual:.2e} (relative) once its "
            "roots far beyond the band are dropped: export the table itself (leave out --fit)"
        )
    num = np.real(gain * np.poly(zeros)) if zeros.size else np.array([gain])
    den = np.real(np.poly(poles)) if poles.size else np.array([1.0])
    return {
        "kind": "fitted",
        "text": transfer.text,
        "num": tuple(num.tolist()),
        "den": tuple(den.tolist()),
        "gain": gain,
        "zeros": tuple(zeros.tolist()),
        "poles": tuple(poles.tolist()),
        "residual": residual,
        "degree": int(fit.degree),
    }


def _far_right(roots: NDArray, high: float) -> NDArray[np.bool_]:
    """Right-half-plane roots far above the band (beyond ``high``): in the band each is
    1 - s/r to within |s/r|, a factor the gain takes; dropping them is measured in the
    residual the export states."""
    return (roots.real > 0) & (np.abs(roots) > high)


def _refuse_artefacts(text: str, zeros: NDArray, poles: NDArray, low: float, high: float) -> None:
    outside = [
        (kind, r)
        for kind, roots in (("zero", zeros), ("pole", poles))
        for r in roots
        if r.real > ORIGIN * low and not low / BAND_MARGIN <= abs(r) <= high * BAND_MARGIN
    ]
    if outside:
        listed = ", ".join(f"a {kind} at {r:.4g}" for kind, r in outside[:4])
        raise SessionError(
            f"--fit: the rational fit of {text} has right-half-plane roots outside the table's band "
            f"({low:.4g}..{high:.4g} rad/s): {listed}; the data say nothing there, so they are the fit's "
            "artefacts: export the table itself (leave out --fit)"
        )


def fit_zeros(fit: RationalFit) -> NDArray[np.complex128]:
    """Zeros of the barycentric numerator (the arrowhead eigenproblem the fit's poles use)."""
    nodes, w = fit.support, fit.weights * fit.values
    n = nodes.size
    if n == 0:
        return np.empty(0, dtype=complex)
    e = np.zeros((n + 1, n + 1), dtype=complex)
    e[0, 0], e[0, 1:], e[1:, 0] = fit.n_inf, w, 1.0
    e[1:, 1:] = np.diag(nodes)
    import scipy.linalg  # on first use: scipy.linalg costs a fifth of a second of start-up

    lam = scipy.linalg.eigvals(e, np.diag(np.r_[0.0, np.ones(n)]))
    keep = np.isfinite(lam) & (np.abs(lam) <= FAR_POLE * np.max(np.abs(nodes)))
    return np.sort_complex(lam[keep])


def _clean(roots: NDArray) -> NDArray:
    """Roots with rounding-level imaginary parts made real."""
    roots = np.asarray(roots, dtype=complex).copy()
    small = np.abs(roots.imag) <= 1e-12 * np.maximum(1.0, np.abs(roots))
    roots[small] = roots[small].real
    return roots

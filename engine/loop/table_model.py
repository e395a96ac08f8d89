"""A tabulated block's rational model: the AAA fit of its table (engine/numerics/rational_fit.py) as
gain, zeros and poles, with its residual measured on the table, as an export writes it for a peer tool
and the step response simulates it.

Right-half-plane roots far above the band (beyond a decade past its top) are dropped, the gain taking
their in-band value, and the residual restated on the table (zeros at +-2e5 rad/s and a gain of 1e-19
were one export's); any other right-half-plane root outside the band (a pole at +8e-7 rad/s) is an
artefact the data cannot justify, and the model is refused, as is one that then misses the table by
more than 1e-3.  `TableModel.realization` is its state space as a cascade of real sections
(first- and second-order): never one polynomial of the fit's degree."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.model.paired_product import PairedProduct
from engine.numerics.rational_fit import FAR_POLE, RationalFit, fit_response

FIT_TOLERANCE = 1e-10  # relative residual asked of a table's fit (the residual reached is stated)
BAND_MARGIN = 10.0  # a root beyond a decade outside the table's frequencies is outside its band
MAX_RESIDUAL = 1e-3  # relative: a fit that misses the table by more (its far roots dropped) is refused
ORIGIN = MAX_RESIDUAL  # relative to the band's bottom: a root this small is at the origin (the table tells it
# from 0 by no more, relatively: a double integrator's fit splits it into +-6e-7 for a table from 0.01 rad/s)


@dataclass(frozen=True)
class TableModel:
    """gain * prod(s - zeros) / prod(s - poles); ``residual``: its largest relative error on the table."""

    gain: float
    zeros: NDArray[np.complex128]
    poles: NDArray[np.complex128]
    residual: float
    degree: int  # the AAA fit's

    def realization(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """A real state space (A, B, C, D): first- and second-order sections in series (`_sections`); an
        `EngineError` when the model is improper (more zeros than poles)."""
        if self.zeros.size > self.poles.size:
            raise EngineError(f"the table's rational model has {self.zeros.size} zeros, {self.poles.size} poles")
        A, B, C, D = np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[self.gain]])
        for zeros, poles in _sections(_conjugate_pairs(self.zeros), _conjugate_pairs(self.poles)):
            num = np.real(np.poly(zeros)) if zeros else np.ones(1)
            a2, b2, c2, d2 = _companion(np.r_[np.zeros(len(poles) - len(zeros)), num], np.real(np.poly(poles)))
            A = np.block([[A, np.zeros((A.shape[0], a2.shape[0]))], [b2 @ C, a2]])
            B, C, D = np.vstack([B, b2 @ D]), np.hstack([d2 @ C, c2]), d2 @ D
        return A, B, C, D


def _sections(zeros: NDArray, poles: NDArray) -> list[tuple[list[complex], list[complex]]]:
    """The roots (in exact conjugate pairs) grouped into real sections of at most two poles: each complex
    pole pair one, the real poles two by two; each complex zero pair to the second-order section of the
    nearest pole with room, then each real zero likewise (the model is proper: every zero has room)."""
    real_poles = [complex(r) for r in np.sort(poles[poles.imag == 0].real)]
    sections: list[tuple[list[complex], list[complex]]] = [([], [r, np.conj(r)]) for r in poles if r.imag > 0]
    sections += [([], real_poles[k : k + 2]) for k in range(0, len(real_poles), 2)]
    groups = [[z, np.conj(z)] for z in zeros if z.imag > 0] + [[complex(z)] for z in zeros if z.imag == 0]
    for group in groups:
        room = [s for s in sections if len(s[1]) - len(s[0]) >= len(group)]
        if not room:
            raise EngineError("the table's rational model has more zeros than poles")
        min(room, key=lambda s: min(abs(p - group[0]) for p in s[1]))[0].extend(group)
    return sections


def _companion(num: NDArray, den: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """A section's controllable companion form (scipy's tf2ss would strip leading numerator coefficients
    it deems negligible: a fit's gain of 2.6e-11 is not)."""
    den = np.trim_zeros(den, "f")
    num = np.asarray(num)[-den.size :] / den[0]  # (a proper section: the leading ones cut are 0)
    den = den / den[0]
    k = den.size - 1
    A = np.vstack([-den[1:], np.eye(k - 1, k)]) if k else np.zeros((0, 0))
    B = np.eye(k, 1)
    d = num[0]
    return A, B, (num[1:] - d * den[1:]).reshape(1, k), np.array([[d]])


PAIRED = 1e-3  # relative: conjugates this close are a pair, an imaginary part this small is rounding


def _conjugate_pairs(roots: NDArray) -> NDArray[np.complex128]:
    """The roots in exact conjugate pairs (a complex root and the nearest conjugate of another within
    `PAIRED`, both made the pair's mean: roots far beyond the band come out of the fit's eigenproblem
    that loose), a root left alone with an imaginary part within `PAIRED` made real; an `EngineError`
    for any other."""
    upper, lower = list(roots[roots.imag > 0]), list(np.conj(roots[roots.imag < 0]))
    kept = [complex(r.real) for r in roots if r.imag == 0]
    for r in upper:
        k = int(np.argmin(np.abs(np.asarray(lower) - r))) if lower else -1
        if k >= 0 and abs(lower[k] - r) <= PAIRED * abs(r):
            mean = (r + lower.pop(k)) / 2
            kept += [mean, np.conj(mean)]
        else:
            lower.append(np.conj(r))  # unpaired: kept real below, or refused
    for r in lower:
        if abs(r.imag) > PAIRED * abs(r):
            raise EngineError(f"the table's rational model has a root {r:.6g} without its conjugate")
        kept.append(complex(r.real))
    return np.array(kept, dtype=complex)


def table_model(omega: NDArray, response: NDArray, text: str, tolerance: float = FIT_TOLERANCE) -> TableModel:
    """The model of the table (frequencies above 0, rad/s; the response there) named ``text``; an
    `EngineError` where it has right-half-plane roots outside the band or misses the table by more than
    `MAX_RESIDUAL`."""
    fit = fit_response(omega, response, tolerance=tolerance)
    low = ORIGIN * float(omega.min())
    zeros, poles = _clean(fit_zeros(fit), low), _clean(np.asarray(fit.poles), low)
    high = BAND_MARGIN * float(omega.max())
    zeros, poles = zeros[~_far_right(zeros, high)], poles[~_far_right(poles, high)]
    both = min(int(np.sum(zeros == 0)), int(np.sum(poles == 0)))  # a zero and a pole put at 0 cancel
    zeros, poles = (
        np.delete(zeros, np.flatnonzero(zeros == 0)[:both]),
        np.delete(poles, np.flatnonzero(poles == 0)[:both]),
    )
    _refuse_artefacts(text, zeros, poles, float(omega.min()), float(omega.max()))
    w0 = float(np.sqrt(omega[0] * omega[-1]))
    shape = PairedProduct(1.0, zeros, poles)
    gain = float((fit(np.array([w0]))[0] / shape.terms(np.array([1j * w0])).value[0]).real)
    model = gain * shape.terms(1j * omega).value
    scale = np.maximum(np.abs(response), 1e-300)
    residual = float(np.max(np.abs(model - response) / scale))
    if not residual <= MAX_RESIDUAL:  # NaN too (a zero in the table)
        raise EngineError(
            f"the rational fit of {text} misses the table by {residual:.2e} (relative) once its roots far "
            "beyond the band are dropped"
        )
    return TableModel(gain, zeros, poles, residual, int(fit.degree))


def _far_right(roots: NDArray, high: float) -> NDArray[np.bool_]:
    """Right-half-plane roots far above the band (beyond ``high``): in the band each is
    1 - s/r to within |s/r|, a factor the gain takes; dropping them is measured in the
    residual stated."""
    return (roots.real > 0) & (np.abs(roots) > high)


def _refuse_artefacts(text: str, zeros: NDArray, poles: NDArray, low: float, high: float) -> None:
    outside = [
        (kind, r)
        for kind, roots in (("zero", zeros), ("pole", poles))
        for r in roots
        if r.real > 0 and not low / BAND_MARGIN <= abs(r) <= high * BAND_MARGIN
    ]
    if outside:
        listed = ", ".join(f"a {kind} at {r:.4g}" for kind, r in outside[:4])
        raise EngineError(
            f"the rational fit of {text} has right-half-plane roots outside the table's band "
            f"({low:.4g}..{high:.4g} rad/s): {listed}; the data say nothing there, so they are the fit's artefacts"
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


def _clean(roots: NDArray, origin: float) -> NDArray:
    """Roots with rounding-level imaginary parts made real, those within ``origin`` of 0 put there (the
    table cannot tell them from an integrator or a differentiator)."""
    roots = np.asarray(roots, dtype=complex).copy()
    small = np.abs(roots.imag) <= 1e-12 * np.maximum(1.0, np.abs(roots))
    roots[small] = roots[small].real
    roots[np.abs(roots) <= origin] = 0.0
    return roots

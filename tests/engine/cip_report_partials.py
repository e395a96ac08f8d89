"""The report's closed-form partials of d(w) for one sub-compensator
(report 000, equations (5-9) to (5-19); Appendix B, (15a,b) and (16)).

With GH = A + jB + (c + jd) N(jw)/D(jw), N = sum x_i s^i and D = sum y_i s^i
(ascending, as the listing reads them), d(w) = |GH|^2 where -(A + jB) already
holds the point pushed from or pulled to.

Reading of the scan: chapter V prints (5-17)/(5-18) as partials with respect
to x and (5-19) with respect to y; the listing (PARCLT: FYE/FYO go to PFY1,
FX1/FX2 to PFX1) and Appendix B (15a,b) and (16) say the opposite, and only
that reading differentiates (5-9) correctly: (5-17)/(5-18) are d/dy, (5-19)
is d/dx.  Appendix B's (16) divides by FN where the listing (FX1 = FN1/FD)
and the derivative divide by FD.  Chapter V keeps the factor 2 the listing
drops (irrelevant once rows are scaled to unit length); it is kept here.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

# the sets (5-10a,b,c): sign pattern by i mod 4, times omega^i
_C = ((1, "c"), (-1, "d"), (-1, "c"), (1, "d"))
_D = ((1, "d"), (1, "c"), (-1, "d"), (-1, "c"))
_E = (1, 1, -1, -1)


def report_partials(
    ab: complex, cd: complex, x: Sequence[float], y: Sequence[float], omega: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(d d/dx_i, d d/dy_i) of d = |ab + cd * N(jw)/D(jw)|^2, by the report's formulas."""
    A, B, c, d = ab.real, ab.imag, cd.real, cd.imag
    part = {"c": c, "d": d}
    C = np.array([_C[i % 4][0] * part[_C[i % 4][1]] * omega**i for i in range(len(x))])
    D = np.array([_D[i % 4][0] * part[_D[i % 4][1]] * omega**i for i in range(len(x))])
    E = np.array([_E[i % 4] * omega**i for i in range(len(y))])
    y = np.asarray(y, dtype=float)
    even, odd = np.arange(len(y)) % 2 == 0, np.arange(len(y)) % 2 == 1
    FD1, FD2 = np.sum(E[even] * y[even]), np.sum(E[odd] * y[odd])
    FN1 = C @ np.asarray(x, dtype=float) + A * FD1 - B * FD2  # (5-11)
    FN2 = D @ np.asarray(x, dtype=float) + A * FD2 + B * FD1  # (5-12)
    FD, FN = FD1**2 + FD2**2, FN1**2 + FN2**2  # (5-15), (5-16)
    dy = np.where(
        even,
        2 * (FD * (A * FN1 + B * FN2) - FN * FD1) * E / FD**2,  # (5-17): y even
        2 * (FD * (-B * FN1 + A * FN2) - FN * FD2) * E / FD**2,
    )  # (5-18): y odd
    dx = 2 * (FN1 * C + FN2 * D) / FD  # (5-19): x
    return dx, dy

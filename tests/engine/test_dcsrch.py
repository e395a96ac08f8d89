"""The carried line search (engine/numerics/line_search.py) against the installed scipy's own
(a private module there, which is why it is carried): the same steps, values and
tasks on random smooth functions along a descent direction."""

from __future__ import annotations

import numpy as np
import pytest

from engine.numerics.line_search import DCSRCH


def _quartic(seed: int):
    rng = np.random.default_rng(seed)
    c = rng.normal(size=5) * [1.0, -3.0, 1.0, 0.5, 0.2]
    c[4] = abs(c[4]) + 0.05  # bounded below: the search ends

    def phi(a: float) -> float:
        return float(np.polyval(c[::-1], a))

    def derphi(a: float) -> float:
        return float(np.polyval(np.polyder(c[::-1]), a))

    if derphi(0.0) >= 0:  # a descent direction, as the line search requires
        c[1] = -abs(c[1]) - 0.1
    return phi, derphi


def test_the_carried_line_search_is_scipys():
    scipy_dcsrch = pytest.importorskip("scipy.optimize._dcsrch").DCSRCH
    settings = dict(ftol=1e-3, gtol=0.9, xtol=0.1, stpmin=0.0, stpmax=10.0)
    found = 0
    for seed in range(40):
        phi, derphi = _quartic(seed)
        ours = DCSRCH(phi, derphi, **settings)(1.0, phi0=phi(0.0), derphi0=derphi(0.0), maxiter=20)
        theirs = scipy_dcsrch(phi, derphi, **settings)(1.0, phi0=phi(0.0), derphi0=derphi(0.0), maxiter=20)
        assert ours == theirs, seed
        found += ours[0] is not None
    assert found >= 30  # most searches found a step: the comparison compared steps

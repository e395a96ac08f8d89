"""Loops of 48-60 poles typed as one expression (issue 49, section 3), seeded: products of real
and complex-pair factors, spread over one to three decades or clustered about a centre (0.3 %
apart), damping from 0.001 to 0.9 and a few unstable factors, a gain up to 1e50; odd seeds have
0-6 zeros, even seeds half as many zeros as poles or more (the gain then sends 10-20 poles out
along asymptotes).  The exact closed-loop poles (unity feedback) are the roots of D + K N
multiplied out from the typed coefficients in mpmath (`exact_poles`)."""

from __future__ import annotations

from typing import NamedTuple

import mpmath
import numpy as np


class ManyPoleLoop(NamedTuple):
    text: str
    gain: float
    zeros: list[list[float]]  # each factor's coefficients, descending, as typed
    poles: list[list[float]]
    integrators: int

    @property
    def order(self) -> int:
        return sum(len(f) - 1 for f in self.poles) + self.integrators


def many_pole_loop(seed: int) -> ManyPoleLoop:
    rng = np.random.default_rng(seed)
    n_poles, integrators = int(rng.integers(48, 61)), int(rng.integers(0, 3))
    n_zeros = int(rng.integers(0, 7)) if seed % 2 else int(rng.integers(n_poles // 2, n_poles - 2))
    low = rng.uniform(-2, 1.5)
    high = low + rng.uniform(1, 3)

    def factors(n: int) -> list[list[float]]:
        out: list[list[float]] = []
        centre = None
        while n > 0:
            if rng.random() < 0.3:
                centre = centre or 10 ** rng.uniform(low, high)
                w = centre * (1 + rng.uniform(-3e-3, 3e-3))
            else:
                w = 10 ** rng.uniform(low, high)
            if n >= 2 and rng.random() < 0.55:
                zeta = float(rng.choice([1e-3, 0.01, 0.05, 0.2, 0.5, 0.9, -0.02]))
                out.append([1.0, float(f"{2 * zeta * w:.8g}"), float(f"{w * w:.8g}")])
                n -= 2
            else:
                sign = 1 if rng.random() < 0.85 else -1
                out.append([1.0, sign * float(f"{w:.8g}")])
                n -= 1
        return out

    zeros, poles = factors(n_zeros), factors(n_poles - integrators)
    gain = float(f"{10 ** rng.uniform(-3, 50):.6g}")
    den = (f"s**{integrators}*" if integrators else "") + "*".join(_text(f) for f in poles)
    text = f"{gain!r}*" + ("*".join(_text(f) for f in zeros) or "1") + f"/({den})"
    return ManyPoleLoop(text, gain, zeros, poles, integrators)


def _text(factor: list[float]) -> str:
    if len(factor) == 3:
        return f"(s**2+{factor[1]!r}*s+{factor[2]!r})"
    return f"(s+{factor[1]!r})" if factor[1] >= 0 else f"(s-{-factor[1]!r})"


def factor_roots(factors: list[list[float]]) -> np.ndarray:
    """The roots of the typed factors (numpy, each factor alone: exact to rounding)."""
    return np.concatenate([np.roots(f) for f in factors] or [np.zeros(0)]).astype(complex)


def exact_poles(loop: ManyPoleLoop, digits: int = 60, extra: int = 200) -> np.ndarray:
    """The roots of D + K N, multiplied out exactly from the typed coefficients (mpmath's
    polyroots at ``digits`` with ``extra`` bits more)."""
    with mpmath.workdps(digits):

        def expand(factors: list[list[float]]) -> list:  # exact: numpy's convolution of mpf objects
            out = np.array([mpmath.mpf(1)], dtype=object)
            for f in factors:
                out = np.convolve(out, np.array([mpmath.mpf(x) for x in f], dtype=object))
            return list(out)

        d = expand(loop.poles) + [mpmath.mpf(0)] * loop.integrators
        n = [mpmath.mpf(loop.gain) * x for x in expand(loop.zeros)]
        p = [a + b for a, b in zip(d, [mpmath.mpf(0)] * (len(d) - len(n)) + n)]
        return np.array([complex(r) for r in mpmath.polyroots(p, maxsteps=400, extraprec=extra)])


def check_pole_list(loop: ManyPoleLoop, exact: np.ndarray) -> None:
    """The analysis's closed-loop poles of ``loop`` are ``exact`` (matched one to one) to 1e-10
    relative (below 1e-50 of the largest root: to that, the reference's own floor at 60 digits), in
    exact conjugate pairs, each shown as a root (backward error within `CONFIRMED`), no fixed mode
    named, and the verdict the exact roots give."""
    from scipy.optimize import linear_sum_assignment

    from engine.analysis import analyze, unity_feedback
    from engine.closed_loop.poles import CONFIRMED

    found = analyze(unity_feedback([loop.text]), "e", np.logspace(-2, 6, 200), {})
    got = np.array([p.value for p in found.closed_loop_poles])
    assert got.size == exact.size == loop.order
    rows, cols = linear_sum_assignment(np.abs(got[:, None] - exact[None, :]))
    error = np.abs(got[rows] - exact[cols])
    assert np.all(error <= 1e-10 * np.abs(exact[cols]) + 1e-50 * np.max(np.abs(exact))), np.max(
        error / np.abs(exact[cols])
    )
    upper, lower = np.sort_complex(got[got.imag > 0]), np.sort_complex(got[got.imag < 0].conj())
    assert np.array_equal(upper, lower)
    assert all(p.backward_error is not None and p.backward_error <= CONFIRMED for p in found.closed_loop_poles)
    assert not any(found.hidden)
    unstable = np.any(exact.real > 1e-12 * np.abs(exact))
    assert (found.verdict == "unstable") == bool(unstable)

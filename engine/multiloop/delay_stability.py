"""Whether a closed loop with time delays is stable, decided by a certified argument count.

With the delays opened and the loop closed with every delay a unit gain (N of
`engine.multiloop.delayed`: states x' = A0 x + ..., A0's eigenvalues the delay-free closed loop's
poles), the delays are r = H z, H = diag(exp(-s tau_k) - 1), and the characteristic function of
the closed loop is

    chi(s) = det(s I - A0) zeta(s),   zeta(s) = det(I - N22(s) H(s)),

an entire function whose zeros are the closed loop's roots.  Around the right half-plane
(up the imaginary axis, back along a large half circle) the roots there number
Z = P - (change of arg zeta) / 2 pi, P the eigenvalues of A0 with Re > 0.

The tail.  For |s| >= W with Re s >= 0, |H_k| <= 2 and |N22(s) - N22(inf)| is bounded from N22's
modes (`engine.multiloop.modal_bounds.Modal.tail`): when q = 2 |N22| <= `TAIL_ROOM`(k) there,
every eigenvalue of I - N22 H lies within q of 1 and arg zeta stays within k asin q < pi/2:
zeta has no zero there and its change of arg from j W round to -j W is -2 arg zeta(j W).
When N22(inf) alone is too large (a delay fed back to itself through direct feedthrough: a
neutral system) the verdict is undecided.

The axis.  zeta(-j omega) is the conjugate of zeta(j omega) and zeta(0) = 1, so the change
up the axis is twice that over [0, W].  On an interval with middle w0 (X = N22 H, X0 there),
zeta / zeta(w0) = det(I - E) with E = (I - X0)^-1 (X - X0); when q = |(I - X0)^-1| |X - X0| < 1
every eigenvalue of I - E lies within q of 1, so arg zeta moves by less than k asin q from its
value at w0; kept below `STEADY` (pi/2 each way), zeta's change of arg over the interval is the
principal angle of zeta(hi) / zeta(lo).  Intervals that
fail are halved, at most `MOST_TESTS` tests and `MOST_SECONDS`: a root on or very near the axis leaves the
verdict undecided, said."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.multiloop.disk import mode_grid
from engine.multiloop.modal_bounds import Modal

ON_AXIS = 1e-12  # |Re p| <= this (1 + |p|): a delay-free closed-loop pole taken as on the imaginary axis
MOST_TESTS = 100_000  # interval tests of the argument count
MOST_DOUBLINGS = 200  # of the tail's frequency W
POINTS_PER_TURN = 8  # first intervals per 2 pi / tau of the longest delay
MOST_START = 20_000  # ... at most
WHOLE = 1e-6  # the count's distance from an integer taken as rounding
STEADY = 0.45 * math.pi  # the most arg zeta may move from an interval's middle (below pi/2: module docstring)
MOST_SECONDS = 10.0  # wall-clock bound of the argument count


@dataclass(frozen=True)
class Verdict:
    """ "stable", "unstable" or "undecided", what it rests on (``note``), the roots counted in Re s > 0."""

    status: str
    note: str
    roots: int = 0


def delays_less_one(taus: NDArray, omega: NDArray) -> NDArray[np.complex128]:
    """H = exp(-j omega tau_k) - 1 at each frequency: points x delays."""
    return np.exp(-1j * np.asarray(omega, dtype=float)[:, None] * taus[None, :]) - 1.0


def delays_moved(taus: NDArray, half: NDArray) -> NDArray[np.float64]:
    """The most any H_k moves within ``half`` of a frequency: 2 sin(tau h / 2), tau the longest delay."""
    return 2.0 * np.sin(np.minimum(taus.max() * half, math.pi) / 2.0)


def tail_room(k: int) -> float:
    """The largest q = 2 |N22| for which k asin q stays below 0.45 pi."""
    return math.sin(0.45 * math.pi / k)


def delayed_verdict(form: Modal, taus: NDArray) -> Verdict:
    """The closed loop's stability (module docstring); ``form``'s rows and columns after its split are the
    delays'."""
    poles = form.poles
    if np.any(np.abs(poles.real) <= ON_AXIS * (1.0 + np.abs(poles))):
        return Verdict("undecided", "a pole of the loop with every delay 0 lies on the imaginary axis")
    top = _tail(form, taus.size)
    if top is None:
        return Verdict(
            "undecided",
            "a delay's loop keeps a direct feedthrough at high frequency (a neutral system): no argument count",
        )
    if not math.isfinite(POINTS_PER_TURN * top * taus.max()):
        return Verdict("undecided", "the loop's modes and delays leave the floating-point range: no argument count")
    turn = _turn(form, taus, top)
    if turn is None:
        return Verdict(
            "undecided",
            f"det(I - N22 H) comes too near 0 on the imaginary axis (limits: {MOST_TESTS} tests, {MOST_SECONDS:g} s)",
        )
    end = complex(_zeta(form, taus, np.array([top]))[0])
    count = int(np.sum(poles.real > 0)) - (turn - math.atan2(end.imag, end.real)) / math.pi
    roots = round(count)
    if abs(count - roots) > WHOLE:
        return Verdict("undecided", f"the argument count {count:.6g} is not a whole number")
    how = f"an argument count of det(I - N22 H) up to {top:.6g} rad/s, the delays exact"
    if roots == 0:
        return Verdict("stable", f"the closed loop with its delays is stable ({how})")
    return Verdict("unstable", f"{roots} root(s) in the right half-plane ({how})", roots)


def _zeta(form: Modal, taus: NDArray, omega: NDArray) -> NDArray[np.complex128]:
    s = form.split
    n22 = form.at(omega)[:, s:, s:]
    h = delays_less_one(taus, omega)
    return np.linalg.det(np.eye(taus.size) - n22 * h[:, None, :])


def _tail(form: Modal, k: int) -> float | None:
    """W beyond which 2 |N22(s)| <= `tail_room` in the closed right half-plane; None if none found."""
    s = form.split
    inf = form.d[s:, s:]
    norm = float(np.linalg.norm(inf, 2))
    room = tail_room(k)
    if 2.0 * norm >= room:
        return None
    sizes = np.abs(form.poles)
    top = 2.0 * (float(sizes.max()) if sizes.size else 1.0)
    x = np.zeros((1, s))
    for _ in range(MOST_DOUBLINGS):
        if 2.0 * (norm + float(form.tail(top, x, True)[1, 1][0])) <= room:
            return top
        top *= 2.0
    return None


def _turn(form: Modal, taus: NDArray, top: float) -> float | None:
    """zeta's change of arg over [0, ``top``] (module docstring); None when `MOST_TESTS` do not do."""
    count = min(MOST_START, int(POINTS_PER_TURN * top * taus.max() / (2.0 * math.pi)) + 2)
    grid = mode_grid(form.poles)
    points = np.unique(np.concatenate([np.linspace(0.0, top, count), grid[grid < top]]))
    lo, hi = points[:-1], points[1:]
    turn, tests, started = 0.0, 0, time.perf_counter()
    while lo.size:
        if tests >= MOST_TESTS or time.perf_counter() - started > MOST_SECONDS:
            return None
        tests += lo.size
        ok = _steady(form, taus, lo, hi)
        turn += float(np.sum(np.angle(_zeta(form, taus, hi[ok]) / _zeta(form, taus, lo[ok]))))
        lo, hi = lo[~ok], hi[~ok]
        mid = 0.5 * (lo + hi)
        lo, hi = np.concatenate([lo, mid]), np.concatenate([mid, hi])
    return turn


def _steady(form: Modal, taus: NDArray, lo: NDArray, hi: NDArray) -> NDArray[np.bool_]:
    """Whether zeta's change of arg over each [lo, hi] stays below pi/2 each way (module docstring)."""
    s, k = form.split, taus.size
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    n22 = form.at(mid)[:, s:, s:]
    h = delays_less_one(taus, mid)
    norm = np.linalg.svd(n22, compute_uv=False)[:, 0]
    eta = np.abs(h).max(axis=1)
    t = delays_moved(taus, half)
    e22 = form.change(lo, hi, np.zeros((lo.size, s)))[1, 1]
    moved = e22 * (eta + t) + norm * t
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = 1.0 / np.linalg.svd(np.eye(k) - n22 * h[:, None, :], compute_uv=False)[:, -1]
        q = np.nan_to_num(inverse * moved, nan=np.inf)
    return (q < 1.0) & (k * np.arcsin(np.minimum(q, 1.0)) < STEADY)

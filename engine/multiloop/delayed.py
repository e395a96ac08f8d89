"""The multi-loop disk margin of a block diagram with time delays exp(-tau s), the delays evaluated
exactly (no Pade approximation).

Form.  The diagram is cut at its breaks and its delays (`engine.loop.realization.realize_opened`),
then closed again with every delay a unit gain: a rational system N(s) from (a disturbance e at
the breaks, r_d at the delays' outputs) to (the breaks' inputs u less e, the delays' inputs z).
The delays are r_d = H z with H = diag(exp(-s tau_k) - 1), so with c = (skew - 1)/2

    M = S + c I = N11 + N12 H (I - N22 H)^-1 N21,   N11 = S0 + c I,

S0 the input sensitivity of the diagram with every delay 0.  N's poles are those of the
delay-free closed loop; |H_k| <= 2 and |dH_k/domega| = tau_k.

Lower bound (alpha_upper).  mu's bounds on a grid of N's modes and of the delays' turns
(`POINTS_PER_TURN` points per 2 pi / tau), the best maximum refined, as for a rational plant
(`engine.multiloop.disk.bracketed`).

Upper bound over frequency (alpha_lower).  gamma a little above the best upper bound found.
On an interval [lo, hi] with middle w0 and one D-scale, sigma_max(D M(j omega) D^-1) is at most
its value at w0 plus a bound of its change (`bounds`): N's change from its modes'
distances to the interval (`engine.multiloop.modal_bounds`), H's change 2 sin(tau h/2), h the
half width, carried through the inverse (I - H N22)^-1 by the Neumann bound; or, second order,
the larger of its values at lo and hi plus Cauchy's bound of M's curvature from its change over
a disc about j w0 (near a flat peak: 709 interval tests where the first order alone took 50721).
An interval whose bound reaches `LOOSE` gamma is bounded again with N frozen at its middle
(`frozen_bound`, at most `MOST_FROZEN` a round: a light mode of N that the delays move away from
the axis is a large term of N's blocks that cancels in M: 1139 tests where 94463 were needed
without it), then, still at gamma or above, halved (its scale optimized at
its middle every few halvings); one whose middle has mu's upper bound at or above gamma is a
higher peak (a restart).  Above a frequency W no interval is needed: there |N - N(inf)| is small
(`Modal.tail`) and, for
every H with |H_k| <= 2, sigma_max(D M D^-1) <= |D N11(inf) D^-1| + its change (`tail_level`);
W is doubled from N's largest mode until that bound is below gamma.  Bounded: `MOST_TESTS`
interval tests, the certificate's time (`engine.multiloop.disk.MOST_SECONDS`), `MOST_DOUBLINGS`.

The closed loop's stability with its delays is decided first (`engine.multiloop.delay_stability`):
not stable, alpha = 0; undecided, alpha_lower = 0 and the reason said, no certificate run."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.loop.realization import OpenedDelays
from engine.margins.disk import check_skew
from engine.model.ports.state_space_ports import balanced_ports
from engine.multiloop import mu
from engine.multiloop.delay_stability import Verdict, delayed_verdict, delays_less_one, delays_moved
from engine.multiloop.disk import (
    LEVEL,
    MOST_SECONDS,
    MultiLoopDiskMargin,
    Peak,
    bracketed,
    candidates,
    mode_grid,
    result,
)
from engine.multiloop.modal_bounds import Modal, modal

POINTS_PER_TURN = 16  # grid points per 2 pi / tau of the longest delay (the lower bound's search)
MOST_GRID = 20_000  # ... at most (a longer grid: the certificate still covers every frequency)
MOST_TESTS = 200_000  # interval tests of one certificate
MOST_DOUBLINGS = 200  # of the tail's frequency W
REOPTIMIZE = 3  # halvings after which an interval's D-scale is optimized again at its middle
LOOSE = 2.0  # an interval bound this many times gamma is tried again with N frozen at its middle
MOST_FROZEN = 100  # ... on at most this many intervals a round (each an eigenvalue problem)
RADII = 4.0 ** np.arange(1, 9)  # the discs' radii tried by the second-order bound, in half widths
CERTIFICATE = "certified per interval by a bound of its change (delays exact)"


@dataclass(frozen=True)
class DelayedLoops:
    """N in modal form (rows and columns: the loops, then the delays), the delays tau_k (s), the grid."""

    modal: Modal
    taus: NDArray[np.float64]
    loops: int
    omega: NDArray[np.float64]
    realization: tuple[NDArray, NDArray, NDArray, NDArray]  # N's (a, b, c, d), balanced

    def parts(self, omega: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        """(N11, N12, N21, N22, h = exp(-j omega tau) - 1) at each frequency."""
        n, m = self.modal.at(omega), self.loops
        h = delays_less_one(self.taus, omega)
        return n[:, :m, :m], n[:, :m, m:], n[:, m:, :m], n[:, m:, m:], h

    def at(self, omega: NDArray) -> NDArray[np.complex128]:
        """M(j omega) at each frequency (module docstring)."""
        n11, n12, n21, n22, h = self.parts(omega)
        r = np.linalg.solve(np.eye(self.taus.size) - h[:, :, None] * n22, h[:, :, None] * np.eye(self.taus.size))
        return n11 + n12 @ r @ n21

    fast = at


def delayed_loops(opened: OpenedDelays, breaks: tuple[str, ...], skew: float) -> DelayedLoops:
    """N of a diagram cut at ``breaks`` (inputs "break NAME") and at its delays (module docstring)."""
    ss = opened.ss
    cols = [ss.inputs.index(f"break {name}") for name in breaks] + list(opened.delay_inputs)
    rows = [ss.outputs.index(name) for name in breaks] + list(opened.delay_outputs)
    d = ss.D[np.ix_(rows, cols)]
    closing = np.eye(len(cols)) - d
    if 1.0 / np.linalg.cond(closing) < 1e-12:
        raise EngineError("I - D of the loops with every delay 0 is singular: the closed loop is not well posed")
    f = np.linalg.inv(closing)  # v = f (C x + r): the loops closed, every delay a unit gain
    a, b, c = ss.A + ss.B[:, cols] @ f @ ss.C[rows], ss.B[:, cols] @ f, f @ ss.C[rows]
    m = len(breaks)
    n_d = f - np.eye(len(cols))
    n_d[:m, :m] += (1.0 + 0.5 * (skew - 1.0)) * np.eye(m)
    realization = balanced_ports(a, b, c, n_d)
    form = modal(*realization, m)
    if form is None:
        raise EngineError(
            "the delay-free closed loop's modes are too ill-conditioned for the delays' certificate "
            "(eigenvectors' condition above 1e8)"
        )
    taus = np.asarray(opened.taus, dtype=float)
    return DelayedLoops(form, taus, m, _search_grid(form, taus), realization)


def _search_grid(form: Modal, taus: NDArray) -> NDArray[np.float64]:
    """0, N's modes' grid and a linear grid over the delays' turns up to 100 times N's largest mode."""
    sizes = np.abs(form.poles)
    top = 100.0 * max(float(sizes.max()) if sizes.size else 1.0, 1.0 / taus.max())
    turns = POINTS_PER_TURN * top * taus.max() / (2.0 * math.pi)
    if not math.isfinite(turns):
        raise EngineError(
            f"the loop's fastest mode ({float(sizes.max()):.3g} rad/s) with its delays leaves the floating-point "
            "range: no grid for the delays' certificate"
        )
    count = min(MOST_GRID, int(turns) + 2)
    return np.unique(np.concatenate([[0.0], mode_grid(form.poles), np.linspace(0.0, top, count)]))


@dataclass(frozen=True)
class _AtMiddle:
    """The scaled blocks' norms at the middles of intervals (`_change`'s inputs): |D M D^-1|, |(I - H N22)^-1|,
    |R| with R = (I - H N22)^-1 H, |D N12|, |N21 D^-1|, |N22|, max |H_k|; and M there, unscaled."""

    sigma: NDArray
    p0: NDArray
    r0: NDArray
    n12: NDArray
    n21: NDArray
    n22: NDArray
    eta: NDArray
    m: NDArray


def _scaled(system: DelayedLoops, omega: NDArray, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """(D M D^-1, (I - H N22)^-1, R) at each of ``omega`` under the log scales ``x`` (points x loops)."""
    n11, n12, n21, n22, h = system.parts(omega)
    d = np.exp(x)
    inverse = np.linalg.inv(np.eye(system.taus.size) - h[:, :, None] * n22)
    r = inverse * h[:, None, :]
    m = d[:, :, None] * (n11 + n12 @ r @ n21) / d[:, None, :]
    return m, inverse, r


def _at_middle(system: DelayedLoops, mid: NDArray, x: NDArray) -> _AtMiddle:
    _, n12, n21, n22, h = system.parts(mid)
    d = np.exp(x)
    m, inverse, r = _scaled(system, mid, x)
    norm = _norms
    return _AtMiddle(
        norm(m),
        norm(inverse),
        norm(r),
        norm(d[:, :, None] * n12),
        norm(n21 / d[:, None, :]),
        norm(n22),
        np.abs(h).max(axis=1),
        m * d[:, None, :] / d[:, :, None],
    )


def _change(at: _AtMiddle, e: dict, t: NDArray) -> NDArray[np.float64]:
    """A bound of |D (M - M0) D^-1| where N's blocks move by at most ``e`` and H by at most ``t`` from the
    middle's (the Neumann bound through (I - H N22)^-1: module docstring)."""
    pi = t * (at.n22 + e[1, 1]) + at.eta * e[1, 1]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        rho = np.where(at.p0 * pi < 1.0, at.p0 * (t + pi * at.r0) / (1.0 - at.p0 * pi), np.inf)
        change = (
            e[0, 0]
            + e[0, 1] * (at.r0 + rho) * (at.n21 + e[1, 0])
            + at.n12 * rho * (at.n21 + e[1, 0])
            + at.n12 * at.r0 * e[1, 0]
        )
    return np.nan_to_num(change, nan=np.inf)


def frozen(system: DelayedLoops, w0: float) -> Modal | None:
    """N' = N with its delays frozen at j w0 (r = H(j w0) z + r'), from (e, r') to (y, z), in modal form
    (None: ill-conditioned): M = N'11 + N'12 H' (I - N'22 H')^-1 N'21 with H' = H - H(j w0), 0 at w0.
    With v = (e, r) and w = (y, z) = c x + d v: v = v' + G w, G = diag(0, H(j w0)), so
    v = (I - G d)^-1 (v' + G c x)."""
    a, b, c, d = system.realization
    m = system.loops
    gain = np.zeros(d.shape, dtype=complex)
    gain[m:, m:] = np.diag(delays_less_one(system.taus, np.array([w0]))[0])
    free = np.linalg.inv(np.eye(d.shape[0]) - gain @ d)
    return modal(a + b @ free @ gain @ c, b @ free, c + d @ free @ gain @ c, d @ free, m)


def frozen_bound(system: DelayedLoops, lo: float, hi: float, x: NDArray) -> float:
    """A bound of sigma_max(D M D^-1) over [lo, hi] from N frozen at its middle (`frozen`): N's modes near
    the axis that the delays move away from it do not enter it (first order: its value at the middle
    plus `_change` with H' = 0 there)."""
    w0, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    form = frozen(system, w0)
    if form is None:
        return math.inf
    m, scales = system.loops, np.exp(x)
    n = form.at(np.array([w0]))[0]
    n11 = scales[:, None] * n[:m, :m] / scales[None, :]
    n12, n21, n22 = scales[:, None] * n[:m, m:], n[m:, :m] / scales[None, :], n[m:, m:]
    norm = _norms
    one, zero = np.ones(1), np.zeros(1)
    at = _AtMiddle(norm(n11[None]), one, zero, norm(n12[None]), norm(n21[None]), norm(n22[None]), zero, n11[None])
    e = form.change(np.array([lo]), np.array([hi]), x[None, :])
    return float(at.sigma[0] + _change(at, e, delays_moved(system.taus, np.array([half])))[0])


def bounds(system: DelayedLoops, lo: NDArray, hi: NDArray, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """(sigma_max(D M D^-1) at the middles, a bound of it over each [lo, hi], M at the middles) under the
    log scales ``x``: the least of two bounds (module docstring).  First order: its value at the middle
    plus its change over the interval.  Second order: M is analytic on the disc |s - j w0| <= r (r in
    `RADII` half widths, at most half the distance to N's nearest mode and ln 2 / tau), where it moves by
    at most B (`_change` with
    N's change over the disc and |exp(-(s - j w0) tau) - 1| <= exp(r tau) - 1); by Cauchy's estimates
    M less its first-order Taylor part is at most B q^2 / (1 - q) on the interval, q = h / r, so M is
    within 2 B q^2 / (1 - q) of the straight line through its ends, whose sigma_max is convex along it:
    at most the larger of sigma_max(D M D^-1) at lo and at hi plus that."""
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    at = _at_middle(system, mid, x)
    tau = system.taus.max()
    first = at.sigma + _change(at, system.modal.change(lo, hi, x), delays_moved(system.taus, half))
    widest = np.minimum(0.5 * system.modal.distance(mid), math.log(2.0) / tau)
    near = np.flatnonzero(half < 0.25 * widest)
    second = np.full(lo.size, np.inf)
    if near.size:
        part = _AtMiddle(*(v[near] for v in vars(at).values()))
        ends = _norms(_scaled(system, np.concatenate([lo[near], hi[near]]), np.concatenate([x[near], x[near]]))[0])
        line = np.maximum(ends[: near.size], ends[near.size :])
        for radius in np.minimum(half[near, None] * RADII[None, :], widest[near, None]).T:
            b = _change(part, system.modal.disc(mid[near], radius, x[near]), np.expm1(radius * tau))
            q = half[near] / radius
            with np.errstate(over="ignore", invalid="ignore"):
                second[near] = np.minimum(second[near], np.nan_to_num(line + 2.0 * b * q**2 / (1.0 - q), nan=np.inf))
    return at.sigma, np.minimum(first, second), at.m


def _norms(m: NDArray) -> NDArray[np.float64]:
    """The spectral norm of each matrix of a stack (0 for an empty one)."""
    if m.shape[-1] == 0 or m.shape[-2] == 0:
        return np.zeros(m.shape[0])
    return np.linalg.svd(m, compute_uv=False)[:, 0]


def tail_level(system: DelayedLoops, top: float, x: NDArray) -> float:
    """A bound of sigma_max(D M(j omega) D^-1) for every omega >= ``top`` (module docstring)."""
    m, inf = system.loops, system.modal.d
    d = np.exp(x)
    n11 = d[:, None] * inf[:m, :m] / d[None, :]
    n12, n21, n22 = d[:, None] * inf[:m, m:], inf[m:, :m] / d[None, :], inf[m:, m:]
    e = {key: float(v[0]) for key, v in system.modal.tail(top, x[None, :], False).items()}
    norm = float(np.linalg.norm(n22, 2)) if n22.size else 0.0
    room = 1.0 - 2.0 * (norm + e[1, 1])
    if room <= 0:
        return math.inf
    n12n, n21n = (float(np.linalg.norm(v, 2)) if v.size else 0.0 for v in (n12, n21))
    return float(np.linalg.norm(n11, 2)) + e[0, 0] + (n12n + e[0, 1]) * (2.0 / room) * (n21n + e[1, 0])


def tail_frequency(system: DelayedLoops, gamma: float) -> float | None:
    """W above which mu < gamma (`tail_level` under a D-scale that makes it small there: Nelder and Mead
    from no scaling, again at each W from the last); None when doubling W `MOST_DOUBLINGS` times does not bring the
    bound below gamma."""
    m = system.loops
    x = np.zeros(m)
    sizes = np.abs(system.modal.poles)
    top = 2.0 * max(float(sizes.max()) if sizes.size else 1.0, float(system.omega.max()))
    for _ in range(MOST_DOUBLINGS):
        if not math.isfinite(2.0 * top):  # (intervals up to it need finite middles)
            return None
        x = _tail_scales(system, top, x)
        if tail_level(system, top, x) < gamma:
            return top
        top *= 2.0
    return None


def _tail_scales(system: DelayedLoops, top: float, start: NDArray) -> NDArray[np.float64]:
    """Log scales lowering `tail_level` at ``top`` (Nelder and Mead from ``start``; the last 0)."""
    from scipy import optimize

    if system.loops == 1:
        return start

    def level(free: NDArray) -> float:
        return tail_level(system, top, np.append(np.clip(free, -mu.SCALE_BOUND, mu.SCALE_BOUND), 0.0))

    found = optimize.minimize(level, start[:-1], method="Nelder-Mead", options={"maxiter": 100 * system.loops})
    return np.append(np.clip(found.x, -mu.SCALE_BOUND, mu.SCALE_BOUND), 0.0) if found.fun < level(start[:-1]) else start


def certify_delayed(system: DelayedLoops, gamma: float, peak: Peak, started: float) -> tuple[str, int, float | None]:
    """(status, interval tests, a higher peak's frequency or None) of mu < gamma at every frequency."""
    top = tail_frequency(system, gamma)
    if top is None:
        return f"tail limit (mu's bound above every frequency W tried stays above {gamma:.6g})", 0, None
    points = np.unique(np.concatenate([system.omega[system.omega < top], [top]]))
    lo, hi = points[:-1], points[1:]
    x = mu.osborne(system.at(0.5 * (lo + hi)))
    age = np.zeros(lo.size, dtype=int)
    tests = 0
    while lo.size:
        if tests >= MOST_TESTS:
            return f"interval limit ({MOST_TESTS} tests)", tests, None
        if time.perf_counter() - started > MOST_SECONDS:
            return f"time limit ({MOST_SECONDS:g} s)", tests, None
        sigma, bound, m0 = bounds(system, lo, hi, x)
        tests += lo.size
        _frozen_where_loose(system, lo, hi, x, bound, gamma)
        bad = np.flatnonzero(bound >= gamma)
        lo, hi, x, age, sigma, m0 = lo[bad], hi[bad], x[bad], age[bad], sigma[bad], m0[bad]
        stale = np.flatnonzero((sigma >= gamma) | (age >= REOPTIMIZE))
        sigma[stale], x[stale] = mu.descended(m0[stale], x[stale])
        age[stale] = 0
        for i in np.flatnonzero(sigma >= gamma):
            high, x[i] = mu.upper(m0[i], x[i])
            if high >= gamma:
                return "higher peak", tests, float(0.5 * (lo[i] + hi[i]))
        mid = 0.5 * (lo + hi)
        lo, hi = np.concatenate([lo, mid]), np.concatenate([mid, hi])
        x, age = np.concatenate([x, x]), np.concatenate([age, age]) + 1
    return "certified", tests, None


def _frozen_where_loose(
    system: DelayedLoops, lo: NDArray, hi: NDArray, x: NDArray, bound: NDArray, gamma: float
) -> None:
    """``bound`` lowered in place by `frozen_bound` on at most `MOST_FROZEN` intervals whose bound is above
    `LOOSE` gamma (about a light mode of N the delays move: its large terms cancel in M)."""
    loose = np.flatnonzero(bound >= LOOSE * gamma)[:MOST_FROZEN]
    for i in loose:
        bound[i] = min(bound[i], frozen_bound(system, float(lo[i]), float(hi[i]), x[i]))


def delayed_disk_margin(
    opened: OpenedDelays, breaks: tuple[str, ...], skew: float = 0.0, stability: Verdict | None = None
) -> MultiLoopDiskMargin:
    """The multi-loop disk margin at ``breaks`` of a diagram whose delays ``opened`` cut (module docstring);
    ``stability``: the closed loop's verdict when the caller has counted it already (the same closed loop
    whatever the breaks), else counted here."""
    skew = check_skew(skew)
    started = time.perf_counter()
    system = delayed_loops(opened, breaks, skew)
    verdict = delayed_verdict(system.modal, system.taus) if stability is None else stability
    if verdict.status == "unstable":
        return _unstable(skew, verdict)
    if verdict.status != "stable":
        return _undecided(system, skew, verdict)
    peak, gamma, status, tests = bracketed(system, system.omega, certify_delayed, started)
    return result(system.loops, skew, peak, gamma, status, tests, CERTIFICATE, (verdict.note,))


def _undecided(system: DelayedLoops, skew: float, verdict: Verdict) -> MultiLoopDiskMargin:
    """Stability undecided: no certificate is run (a bound of mu over frequency is a margin only for a
    stable closed loop), alpha_lower 0 and why; alpha_upper from the grid's best peak (a perturbation
    found there destabilizes whatever the verdict), inf when mu cannot be evaluated on the grid (a
    delay-free pole on the axis makes N infinite there)."""
    status = f"stability undecided: {verdict.note}"
    skipped = "the certificate over frequency is not run: it bounds mu of a stable closed loop only"
    try:
        with np.errstate(all="ignore"):
            peak = candidates(system, system.omega)
    except np.linalg.LinAlgError as exc:
        note = f"mu could not be evaluated on the grid ({exc}): alpha_upper unknown (inf)"
        return MultiLoopDiskMargin(
            0.0, 0.0, math.inf, skew, 1.0, 1.0, 0.0, math.nan, status, (), (verdict.note, skipped, note), 0, CERTIFICATE
        )
    gamma = max(peak.high, peak.low) * (1.0 + LEVEL)
    return result(system.loops, skew, peak, gamma, status, 0, CERTIFICATE, (verdict.note, skipped))


def _unstable(skew: float, verdict: Verdict) -> MultiLoopDiskMargin:
    note = f"the closed loop is not stable ({verdict.note}): no disk margin (alpha = 0)"
    return MultiLoopDiskMargin(0.0, 0.0, 0.0, skew, 1.0, 1.0, 0.0, math.nan, "unstable", (), (note,), 0, CERTIFICATE)

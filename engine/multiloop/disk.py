"""The multi-loop disk margin (Seiler, Packard and Gahinet 2020, section 4): independent
complex perturbations f_i = (1 + (1 - sigma)/2 delta_i) / (1 - (1 + sigma)/2 delta_i) at
every input at once keep the closed loop stable for every |delta_i| < alpha, with

    alpha = 1 / max over omega of mu(M(j omega)),   M = S + (sigma - 1)/2 I,

S the input sensitivity and mu that of the diagonal complex structure (`engine.multiloop.mu`).

Search.  mu's bounds on a grid (Osborne-scaled singular values, and the spectral radius at
the singular vectors' phases: batched over every point), around every closed-loop mode;
the best local maxima are refined by Nelder and Mead on (log omega, phases) maximizing
rho(M Q), which keeps the destabilizing perturbation: alpha_upper = 1 / that rho.  Also
omega = 0 and omega = inf.

Certificate.  gamma a little above the best upper bound found (`LEVEL`): the frequency axis
is covered by intervals, each with one fixed D-scale under which sigma_max(D M D^-1) < gamma
on the whole interval (`engine.multiloop.hamiltonian`: no crossing of gamma inside, and one
point below it).  An interval where the scale does not do is split at the crossings and its
parts get scales optimized at their middle.  Then mu < gamma at every frequency, and
alpha_lower = 1 / gamma.  A part whose middle has mu's upper bound at or above gamma is a
higher peak: the search moves there and starts over (`RESTARTS`).  Bounded: `MOST_INTERVALS`
interval tests, `MOST_SECONDS`; the status names the bound that bites.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from engine.margins.disk import GuaranteedGains, check_skew, disk_gain_phase
from engine.multiloop import mu
from engine.multiloop.hamiltonian import crossings, response
from engine.multiloop.modal_bounds import modal
from engine.multiloop.plant import Plant, closed_loop_poles, sensitivity

GAP = 1e-6  # the relative gap between alpha_lower and alpha_upper promised when certified
LEVEL = 2e-7  # gamma = the upper bound's peak * (1 + LEVEL): the certificate's margin
MOST_INTERVALS = 400  # interval tests (one Hamiltonian eigenvalue problem each)
MOST_SECONDS = 10.0  # wall-clock bound of one certificate
RESTARTS = 6  # higher peaks found by the certificate before it gives up
STABLE = 1e-12  # a closed-loop pole with Re >= -STABLE (1 + |A|) is taken as not stable
PER_DECADE = 24  # grid points a decade
REFINED = 1  # local maxima of the grid refined (a higher one missed: the certificate finds it)
CLOSE = 0.8  # ... those at least this fraction of the best
EXACT_UP_TO = 3  # scalar blocks for which mu's D-scale bound is mu
CHECK_POINTS = 6  # points inside each accepted interval where the scaled norm is checked again
NUDGE = 1e-3  # log-scale step away from a scale under which gamma is a singular value of the feedthrough
MODAL_CONDITION = 1e6  # cond(V) of the closed loop's eigenvectors up to which the searches use the modal sum
HAMILTONIAN = "Hamiltonian-certified per interval"  # how the upper bound over frequency is certified


@dataclass(frozen=True)
class MultiLoopDiskMargin(GuaranteedGains):
    """alpha_lower <= alpha <= alpha_upper (``alpha`` reported: the certified alpha_lower);
    the gain and phase it guarantees at every loop at once, the worst frequency, the
    destabilizing perturbation there (``delta``, one complex number a loop) and a status:
    "certified" (gap at most `GAP`), "unstable", or the bound that stopped the certificate."""

    alpha: float
    alpha_lower: float
    alpha_upper: float
    skew: float
    gain_low: float
    gain_high: float
    phase_deg: float
    frequency: float
    status: str
    delta: tuple[complex, ...] = ()
    notes: tuple[str, ...] = field(default=())
    intervals: int = 0
    certificate: str = HAMILTONIAN

    @property
    def method(self) -> str:
        return f"mu (diagonal complex, D-scales), {self.certificate}: {self.status}"

    @property
    def gap(self) -> float:
        return (self.alpha_upper - self.alpha_lower) / self.alpha_upper if self.alpha_upper > 0 else 0.0


class System:
    """M = S + (skew - 1)/2 I as (a, b, c, d): ``at`` by a solve at each point (what the bounds
    reported are read from), ``fast`` by the modal sum when A's eigenvectors are well conditioned
    (the searches: a few array operations a point)."""

    def __init__(self, a: NDArray, b: NDArray, c: NDArray, d: NDArray) -> None:
        self.a, self.b, self.c, self.d = a, b, c, d
        self.form = modal(a, b, c, d, d.shape[0], MODAL_CONDITION) if a.shape[0] else None

    def at(self, omega: NDArray) -> NDArray[np.complex128]:
        return response(self.a, self.b, self.c, self.d, omega)

    def fast(self, omega: NDArray) -> NDArray[np.complex128]:
        return self.at(omega) if self.form is None else self.form.at(omega)

    def scaled(self, x: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        s = np.exp(x)
        return self.a, self.b / s[None, :], s[:, None] * self.c, s[:, None] * self.d / s[None, :]


@dataclass
class Peak:
    omega: float
    low: float
    delta: NDArray
    high: float = 0.0
    scales: NDArray = field(default_factory=lambda: np.zeros(0))


def _unstable(skew: float, poles: NDArray) -> MultiLoopDiskMargin:
    worst = poles[np.argmax(poles.real)]
    note = f"the closed loop is not stable (pole {worst:.6g}): no disk margin (alpha = 0)"
    return MultiLoopDiskMargin(0.0, 0.0, 0.0, skew, 1.0, 1.0, 0.0, math.nan, "unstable", (), (note,))


def grid(plant: Plant, poles: NDArray) -> NDArray[np.float64]:
    """Frequencies spanning every open- and closed-loop mode, denser about light ones."""
    return mode_grid(np.concatenate([poles, np.linalg.eigvals(plant.A) if plant.order else np.zeros(0)]))


def mode_grid(modes: NDArray) -> NDArray[np.float64]:
    """Frequencies spanning every one of ``modes``, denser about light ones."""
    sizes = np.abs(modes[np.abs(modes) > 0])
    low, high = (sizes.min() / 100.0, sizes.max() * 100.0) if sizes.size else (1e-2, 1e2)
    count = int(min(2000, max(50, PER_DECADE * math.log10(high / low))))
    near = [np.abs(p.imag) + abs(p.real) * np.array([-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0]) for p in modes]
    extra = np.concatenate(near) if near else np.zeros(0)
    points = np.concatenate([np.geomspace(low, high, count), extra[extra > 0]])
    return np.unique(points)


def _grid_peaks(system: System, omega: NDArray) -> list[Peak]:
    """The best `REFINED` local maxima of the batched lower bound on the grid ``omega`` (its ends included)."""
    m = system.fast(omega)
    x = mu.osborne(m)
    phases = mu.vector_phases(m, x)
    low = np.abs(np.linalg.eigvals(m * np.exp(1j * phases)[:, None, :])).max(axis=1)
    low = np.maximum(low, np.abs(np.diagonal(m, axis1=1, axis2=2)).max(axis=1))
    interior = np.flatnonzero(np.r_[True, low[1:] >= low[:-1]] & np.r_[low[:-1] >= low[1:], True])
    best = interior[np.argsort(low[interior])[::-1][:REFINED]]
    best = best[low[best] >= CLOSE * low[best[0]]]
    return [Peak(float(omega[k]), float(low[k]), np.zeros(0)) for k in best]


def refined(system: System, start: float) -> Peak:
    """Nelder and Mead on (log omega, phases) maximizing rho(M Q) from ``start`` and the phases of mu's
    lower bound there (module docstring); the better of its end and ``start``."""
    from scipy import optimize

    first = at_point(system, start)
    delta = np.asarray(first.delta)
    phases0 = np.angle(delta) - np.angle(delta[-1]) if first.low > 0 else np.zeros(delta.size)

    def f(v: NDArray) -> float:
        m = system.fast(np.array([math.exp(v[0])]))[0]
        return -mu.radius(m, np.append(v[1:], 0.0))[0]

    v0 = np.append(math.log(start), phases0[:-1])
    found = optimize.minimize(
        f, v0, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-13 * first.low, "maxiter": 200 * len(v0)}
    )
    if not -found.fun > first.low:
        return first
    other = at_point(system, math.exp(found.x[0]))
    return other if other.low > first.low else first


def at_point(system: System, omega: float) -> Peak:
    b = mu.bracket(system.at(np.array([omega]))[0])
    return Peak(omega, b.low, b.delta, b.high, b.scales)


def candidates(system: System, omega: NDArray) -> Peak:
    """The best peak: the refined maxima of the grid ``omega`` (0 or inf among them: taken as they are)."""
    found = [
        refined(system, p.omega) if 0 < p.omega < math.inf else at_point(system, p.omega)
        for p in _grid_peaks(system, omega)
    ]
    return max(found, key=lambda p: p.low)


def _value(system: System, x: NDArray, omega: float) -> float:
    return float(np.linalg.norm(mu.scaled(system.at(np.array([omega]))[0], x), 2))


def _middle(lo: float, hi: float) -> float:
    if hi == math.inf:
        return max(2.0 * lo, 1.0)
    return math.sqrt(lo * hi) if lo > 0 else hi / 2.0


@dataclass
class _Cover:
    """The certificate's work: intervals to test (lo, hi, scales), tests made, a higher peak found."""

    todo: list
    tests: int = 0
    higher: float | None = None
    covered: list = field(default_factory=list)  # (lo, hi, scales) accepted


def _test(system: System, gamma: float, lo: float, hi: float, x: NDArray, cover: _Cover) -> None:
    """One interval under one scale: the parts above gamma go back on the list with new scales."""
    cover.tests += 1
    cut = crossings(*system.scaled(x), gamma)
    if cut is None:  # gamma a singular value of the scaled feedthrough: no test; again with a scale moved
        cover.todo.append((lo, hi, x + NUDGE * np.arange(x.size)[::-1]))
        return
    points = [lo, *cut[(cut > lo) & (cut < hi)], hi]
    for a, b in zip(points[:-1], points[1:]):
        w = _middle(a, b)
        if b <= a:
            continue
        if _value(system, x, w) < gamma:
            cover.covered.append((a, b, x))
        else:
            high, scales = mu.upper(system.at(np.array([w]))[0], x)
            if high >= gamma:
                cover.higher = w
                return
            cover.todo.append((a, b, scales))


def certify(system: System, gamma: float, peak: Peak, started: float) -> tuple[str, int, float | None]:
    """(status, interval tests, a higher peak's frequency or None) of mu < gamma at every frequency."""
    cover = _Cover([(0.0, math.inf, peak.scales)])
    while cover.todo:
        if cover.tests >= MOST_INTERVALS:
            return f"interval limit ({MOST_INTERVALS} tests)", cover.tests, None
        if time.perf_counter() - started > MOST_SECONDS:
            return f"time limit ({MOST_SECONDS:g} s)", cover.tests, None
        lo, hi, x = cover.todo.pop()
        _test(system, gamma, lo, hi, x, cover)
        if cover.higher is not None:
            return "higher peak", cover.tests, cover.higher
    if not _checked(system, gamma, cover.covered):
        return "check failed (a covered interval's scaled norm reaches gamma between its crossings)", cover.tests, None
    return "certified", cover.tests, None


def _checked(system: System, gamma: float, covered: list) -> bool:
    """Every accepted interval's scaled norm below gamma at `CHECK_POINTS` more points inside it: a
    crossing the eigenvalue test missed (an ill-conditioned eigenvalue off the axis) shows here."""
    for lo, hi, x in covered:
        top = hi if math.isfinite(hi) else max(4.0 * lo, 1e3 * max(lo, 1.0))
        inside = np.geomspace(max(lo, top * 1e-9), top, CHECK_POINTS + 2)[1:-1] if top > 0 else np.zeros(0)
        m = mu.scaled(system.at(inside), x)
        if inside.size and np.linalg.svd(m, compute_uv=False)[:, 0].max() >= gamma:
            return False
    return True


Certify = Callable[[Any, float, Peak, float], tuple[str, int, float | None]]


def multi_loop_disk_margin(plant: Plant, skew: float = 0.0) -> MultiLoopDiskMargin:
    """The multi-loop disk margin of ``plant`` at its inputs (module docstring)."""
    skew = check_skew(skew)
    started = time.perf_counter()
    poles = closed_loop_poles(plant)
    if poles.size and poles.real.max() >= -STABLE * (1.0 + np.abs(plant.A).sum(axis=0).max()):
        return _unstable(skew, poles)
    a, b, c, d = sensitivity(plant)
    system = System(a, b, c, d + 0.5 * (skew - 1.0) * np.eye(plant.loops))
    omega = np.concatenate([[0.0], grid(plant, poles), [math.inf]])
    peak, gamma, status, tests = bracketed(system, omega, certify, started)
    return result(plant.loops, skew, peak, gamma, status, tests)


def bracketed(system: Any, omega: NDArray, certifier: Certify, started: float) -> tuple[Peak, float, str, int]:
    """(the best peak, the level gamma certified or tried last, the status, interval tests): the peak of
    the grid ``omega`` refined, then ``certifier``'s test of mu < gamma over every frequency, moving to a
    higher peak it finds at most `RESTARTS` times."""
    peak = candidates(system, omega)
    status, tests, gamma = "higher peak", 0, math.inf
    for _ in range(RESTARTS):
        gamma = max(peak.high, peak.low) * (1.0 + LEVEL)
        status, used, higher = certifier(system, gamma, peak, started)
        tests += used
        if higher is None:
            return peak, gamma, status, tests
        better = refined(system, higher)
        peak = better if better.low > peak.low else at_point(system, higher)
    return peak, gamma, f"restart limit ({RESTARTS} higher peaks)", tests


def result(
    loops: int,
    skew: float,
    peak: Peak,
    gamma: float,
    status: str,
    tests: int,
    certificate: str = HAMILTONIAN,
    notes: tuple[str, ...] = (),
) -> MultiLoopDiskMargin:
    """The margin from the peak's lower bound and the certified level (module docstring)."""
    certified = status == "certified"
    alpha_upper = 1.0 / peak.low if peak.low > 0 else math.inf
    alpha_lower = 1.0 / gamma if certified else 0.0
    notes_out = list(notes)
    if not certified:
        notes_out.append(
            f"not certified: {status}; alpha_lower 0 (the best upper bound of mu found gives {1.0 / gamma:.6g})"
        )
    gap = (alpha_upper - alpha_lower) / alpha_upper if math.isfinite(alpha_upper) and alpha_upper > 0 else 0.0
    if certified and gap > GAP:
        why = (
            f"mu's D-scale bound exceeds mu for {loops} scalar blocks"
            if loops > EXACT_UP_TO
            else "the lower bound's search fell short"
        )
        status = f"gap {gap:.2e} ({why})"
        notes_out.append(f"alpha is bracketed to {gap:.2e} relative: {why}")
    low, high, phase = disk_gain_phase(alpha_lower, skew) if math.isfinite(alpha_lower) else (0.0, math.inf, 90.0)
    return MultiLoopDiskMargin(
        alpha_lower,
        alpha_lower,
        alpha_upper,
        skew,
        low,
        high,
        phase,
        peak.omega,
        status,
        tuple(complex(v) for v in peak.delta),
        tuple(notes_out),
        tests,
        certificate,
    )

"""Root loci: the closed-loop poles as a function of the loop gain k
(1 + k L(s) = 0) or of any named parameter of the network.

Branches are followed by adaptive continuation: a step is accepted when no
pole moved by more than `MOVE` of its size nor more than `SEPARATE` of its
distance to the nearest other pole, else it is halved (down to a floor
where poles collide, at breakaway points); the poles of consecutive points
are matched by nearest assignment (`linear_sum_assignment`).  The points are
bounded (``max_points``; status ``"point budget reached"``).  Gain loci
step on the eigenvalues of A - k B (1 + k D)^-1 C and polish each point kept
on the network's characteristic equation (`engine.closed_loop.characteristic`: Aberth's
iteration, clusters at breakaway points solved as units; for drawing, only
the points whose eigenvalues are noisy, and on the loop's pole-zero form);
where the eigenvalues are noisy (~10 % off to wholly wrong at large gains)
the steps they reject are judged on polished points.
Parameter loci polish as `engine.closed_loop.poles` does.  Crossings of the imaginary
axis are refined by brentq; gain loci also carry asymptotes and breakaway
points."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy import linalg
from scipy.optimize import brentq, linear_sum_assignment

from engine.closed_loop.characteristic import FormCharacteristic, GainCharacteristic
from engine.closed_loop.poles import polish
from engine.errors import EngineError
from engine.loop.design import design
from engine.loop.pole_zero import ZpkEvaluator
from engine.loop.responses import loop_model
from engine.margins.search import margins
from engine.model.bilinear import real_frequency, z_of_w
from engine.model.network import Network

MOVE = 0.05  # a step may move a pole by this fraction of max(|pole|, the floor)
SEPARATE = 0.25  # ... and by this fraction of its distance to the nearest other pole
FLOOR = 1e-3  # of the largest pole: the size below which poles count as this size
FIRST_STEPS = 50  # the first step: this fraction of the range
NOISE_MOVE = 1e-8  # a move this small (relative) is always allowed: the roots' own noise
MIN_STEP = 1e-10  # of the range: a step this small is accepted whatever moved (poles collide)
NOISY = 0.1  # raw roots off the refined ones by this fraction of a step's allowed move: judged refined
DRAWN = 1e-6  # drawing: eigenvalues kept whose polish would move them by less (relative) and < NOISY
MAX_POINTS = 2000
EVALUATIONS_PER_POINT = 4  # rejected steps count too: at most this many evaluations per point
GAIN_DECADES = 3.0  # the default gain range: 1e-3..1e3 times the crossings' span


@dataclass(frozen=True)
class Crossing:
    """A branch crossing the imaginary axis: the parameter value there, the
    frequency |Im s| (rad/s), the pole, and +1 into the right half-plane, -1 out."""

    value: float
    frequency: float
    pole: complex
    direction: int


@dataclass(frozen=True)
class RootLocus:
    """Branches (``branches[i, j]``: pole j at ``values[i]``) of the parameter
    ``parameter`` ("gain" for k in 1 + k L = 0), the current value and its poles."""

    parameter: str
    values: NDArray[np.float64]
    branches: NDArray[np.complex128]
    current_value: float
    current: tuple[complex, ...]
    crossings: tuple[Crossing, ...]
    status: str  # "complete", "point budget reached" or what stopped it
    centroid: float | None = None  # gain loci: the asymptotes' centre and angles (deg)
    angles_deg: tuple[float, ...] = ()
    breakaways: tuple[tuple[complex, float], ...] = ()  # gain loci: (point, gain)
    notes: tuple[str, ...] = field(default=())


@dataclass(frozen=True)
class PoleZeroMap:
    """The open loop's poles, zeros and gain (L = gain prod(s - z)/prod(s - p)) and the closed-loop poles."""

    poles: NDArray[np.complex128]
    zeros: NDArray[np.complex128]
    gain: float
    closed_loop: NDArray[np.complex128]


def pole_zero_map(network: Network, break_at: str, params: Mapping[str, float]) -> PoleZeroMap:
    """The pole-zero map of the loop broken at ``break_at`` (rational loops; a sampled loop's in z)."""
    if network.sample_time is not None:
        found = pole_zero_map(network.unsampled(), break_at, params)
        return replace(
            found, poles=z_of_w(found.poles), zeros=z_of_w(found.zeros), closed_loop=z_of_w(found.closed_loop)
        )
    (form, _), eigenvalues = _loop_form(network, break_at, params), _gain_eigenvalues(network, break_at, params)
    polish = GainCharacteristic(network, break_at, params).polish
    open_loop, closed_loop = polish(0.0, eigenvalues(0.0)), polish(1.0, eigenvalues(1.0))
    return PoleZeroMap(open_loop, form.zeros, float(form.gain.real), closed_loop)


def root_locus(
    network: Network,
    break_at: str,
    params: Mapping[str, float],
    parameter: str = "gain",
    value_range: tuple[float, float] | None = None,
    max_points: int = MAX_POINTS,
    polished: bool = True,
) -> RootLocus:
    """The locus in the loop gain (``parameter="gain"``) or in a named parameter of the
    network; ``polished`` False: for drawing, a gain locus polished only where the eigenvalues
    are noisy, and on the loop's pole-zero form (`gain_locus`): ~30x faster."""
    if not network.rational:
        raise EngineError("a root locus needs a rational loop (no delays, no tables)")
    if not (isinstance(max_points, int) and 2 <= max_points <= 100_000):
        raise EngineError(f"a root locus has 2..100000 points, not {max_points!r}")
    if value_range is not None:
        lo, hi = (float(v) for v in value_range)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise EngineError(f"a locus range must be finite with low < high, not {value_range!r}")
    if network.sample_time is not None:
        found = root_locus(network.unsampled(), break_at, params, parameter, value_range, max_points, polished)
        return sampled_locus(found, network.sample_time)
    if parameter == "gain":
        return gain_locus(network, break_at, params, value_range, max_points, polished)
    if parameter not in network.parameters:
        known = ", ".join(network.parameters) or "none"
        raise EngineError(f"no parameter {parameter!r} to draw a locus in (parameters: {known}; or 'gain')")
    return parameter_locus(network, params, parameter, value_range, max_points)


def sampled_locus(found: RootLocus, sample_time: float) -> RootLocus:
    """A sampled loop's locus, found in w, in z: its crossings those of the unit circle, at
    omega = (2/T) atan(nu) rad/s; no asymptotes (in z they are arcs to z = -1, not lines)."""
    crossings = tuple(
        replace(x, frequency=float(real_frequency(x.frequency, sample_time)), pole=complex(z_of_w(x.pole)))
        for x in found.crossings
    )
    return replace(
        found,
        branches=z_of_w(found.branches),
        current=tuple(complex(z) for z in z_of_w(found.current)),
        crossings=crossings,
        centroid=None,
        angles_deg=(),
        breakaways=tuple((complex(z_of_w(p)), k) for p, k in found.breakaways),
        notes=found.notes + (f"in z (T = {sample_time:g} s): found on the w-plane form, z = (1 + w)/(1 - w)",),
    )


def gain_locus(
    network: Network,
    break_at: str,
    params: Mapping[str, float],
    value_range: tuple[float, float] | None = None,
    max_points: int = MAX_POINTS,
    polished: bool = True,
) -> RootLocus:
    """Closed-loop poles of 1 + k L(s) = 0 for k from 0 over ``value_range``
    (default: 1e-3..1e3 around 1 and every imaginary-axis crossing).  Not ``polished`` (drawn):
    eigenvalues within DRAWN of the polished roots and within NOISY of a step's move (by Aberth's
    first correction: to the eye the same, and not noisy) kept as they are, the others polished on
    the loop's pole-zero form (a few numpy operations an evaluation, not the blocks' expressions)."""
    form, notes = _loop_form(network, break_at, params)
    characteristic = GainCharacteristic(network, break_at, params) if polished else FormCharacteristic(form)
    eigenvalues = _gain_eigenvalues(network, break_at, params)

    def polish(k: float, eig: NDArray) -> NDArray:
        quiet = None if polished else np.minimum(NOISY * _allowed(eig), DRAWN * np.abs(eig))
        return characteristic.polish(k, eig, quiet)

    def roots_at(k: float) -> NDArray:
        return polish(k, eigenvalues(k))

    lo, hi = value_range if value_range is not None else _gain_range(network, break_at, params)
    if lo <= 0:
        raise EngineError(f"a gain locus runs over positive gains (it starts at k = 0), not from {lo!r}")
    # the steps are chosen on the eigenvalues, the points kept polished (and the steps judged on
    # polished points where the eigenvalues are noisy: see `continuation`)
    ts, rows, status = continuation(
        lambda t: eigenvalues(math.exp(t)),
        math.log(lo),
        math.log(hi),
        [0.0] if lo < 1.0 < hi else [],
        max_points,
        lambda t, row: polish(math.exp(t), row),
    )
    values = np.concatenate([[0.0], np.exp(ts)])
    branches = np.vstack([_matched(rows[0], roots_at(0.0))[None, :], rows])
    crossings = _crossings(roots_at, values[1:], branches[1:])
    centroid, angles = _asymptotes(form)
    return RootLocus(
        "gain",
        values,
        branches,
        1.0,
        tuple(roots_at(1.0).tolist()),
        crossings,
        status,
        centroid,
        angles,
        _breakaways(form),
        tuple(notes),
    )


def parameter_locus(
    network: Network,
    params: Mapping[str, float],
    name: str,
    value_range: tuple[float, float] | None = None,
    max_points: int = MAX_POINTS,
) -> RootLocus:
    """Closed-loop poles as ``name`` runs over ``value_range`` (default: a
    decade either side of its value; -1..1 about 0), from the realization."""
    current = float(params[name])
    lo, hi = (
        value_range
        if value_range is not None
        else (
            (current / 10, current * 10)
            if current > 0
            else (current * 10, current / 10)
            if current < 0
            else (-1.0, 1.0)
        )
    )

    def roots_at(v: float) -> NDArray:
        values = dict(params) | {name: v}
        ss = design(network, values).closed_realization
        eig = np.linalg.eigvals(ss.A) if ss.A.size else np.zeros(0, dtype=complex)
        return polish(network, values, eig) if eig.size else eig

    logarithmic = lo > 0
    to_t, from_t = (math.log, math.exp) if logarithmic else (float, float)
    nodes = [to_t(current)] if lo < current < hi else []
    ts, rows, status = continuation(lambda t: roots_at(from_t(t)), to_t(lo), to_t(hi), nodes, max_points)
    values = np.exp(ts) if logarithmic else ts
    return RootLocus(
        name, values, rows, current, tuple(roots_at(current).tolist()), _crossings(roots_at, values, rows), status
    )


def continuation(
    roots_at: Callable[[float], NDArray],
    t0: float,
    t1: float,
    nodes: Sequence[float] = (),
    max_points: int = MAX_POINTS,
    refine: Callable[[float, NDArray], NDArray] | None = None,
) -> tuple[NDArray, NDArray, str]:
    """Roots of ``roots_at(t)`` followed from t0 to t1 by adaptive steps
    (module docstring), passing through every node; (t, rows, status).
    ``refine(t, roots)`` makes raw roots accurate: every row kept is refined, and
    a step is judged on the refined roots where the raw ones are noisy (see `_refined`):
    at the new row, or at the last row kept and rejecting it."""
    span = t1 - t0
    first = np.asarray(roots_at(t0), dtype=complex)
    roots, noisy = _refined(refine, t0, first, first)
    ts, rows = [t0], [roots]
    t, step, status = t0, span / FIRST_STEPS, "complete"
    stops = sorted(n for n in nodes if t0 < n < t1) + [t1]
    for _ in range(EVALUATIONS_PER_POINT * max_points):
        if t >= t1:
            break
        if len(ts) >= max_points:
            status = "point budget reached"
            break
        forced = step <= MIN_STEP * span
        target = min(t + step, next(s for s in stops if s > t))
        try:
            new = _matched(roots, np.asarray(roots_at(target), dtype=complex))
        except EngineError as exc:
            status = f"stopped at {target:.6g}: {exc}"
            break
        ratio, judged = _move_ratio(roots, new), None
        if not forced and (ratio <= 1.0 or noisy):
            judged = _refined(refine, target, new, roots)
            if judged[1] or ratio > 1.0:
                ratio = _move_ratio(roots, judged[0])
        grow = min(1.5, 0.7 / ratio) if ratio > 0 else 1.5  # NaN: shrink
        if ratio <= 1.0 or forced:
            t, (roots, noisy) = target, judged or _refined(refine, target, new, roots)
            ts.append(t)
            rows.append(roots)
            step = min(max(step * grow, MIN_STEP * span), span / 20)
        else:
            step = max((target - t) * max(0.2, grow if grow == grow else 0.2), MIN_STEP * span)
    else:
        status = "step budget reached"
    return np.array(ts), np.array(rows).reshape(len(rows), first.size), status


def _refined(
    refine: Callable[[float, NDArray], NDArray] | None, t: float, raw: NDArray, previous: NDArray
) -> tuple[NDArray, bool]:
    """The row kept for ``raw`` at t (refined, matched to the ``previous`` row: raw roots that
    noisy may be matched wrongly), and whether ``raw`` was too noisy to judge steps by: off the
    refined roots by more than NOISY of a step's allowed move (the eigenvalues of a gain locus
    at large gains, where |A - k B C| is huge, or near a breakaway point; judged on them alone
    the steps shrink to their floor there and the point budget runs out)."""
    refined = raw if refine is None else refine(t, raw)
    if refined is raw:  # not refined (a drawn locus: not noisy)
        return raw, False
    refined = np.asarray(refined, dtype=complex)
    beside = _matched(raw, refined)
    return _matched(previous, refined), bool(np.any(np.abs(beside - raw) > NOISY * _allowed(beside)))


def _matched(old: NDArray, new: NDArray) -> NDArray:
    """``new`` ordered so that new[i] is the pole nearest old[i] (an assignment)."""
    if old.size != new.size:
        raise EngineError(f"the number of closed-loop poles changes ({old.size} -> {new.size})")
    if old.size == 0:
        return new
    cost = np.abs(old[:, None] - new[None, :])
    rows, cols = linear_sum_assignment(cost)
    out = np.empty_like(new)
    out[rows] = new[cols]
    return out


def _move_ratio(old: NDArray, new: NDArray) -> float:
    """The largest move as a fraction of what a step allows (<= 1: accepted)."""
    if old.size == 0:
        return 0.0
    with np.errstate(all="ignore"):
        ratio = np.abs(new - old) / _allowed(old)
    return float(np.max(np.where(np.isfinite(ratio), ratio, np.inf)))


def _allowed(old: NDArray) -> NDArray:
    """How far each pole may move in one step (module docstring)."""
    if old.size == 0:
        return np.zeros(0)
    size = np.abs(old)
    floor = FLOOR * max(float(np.max(size)), 1e-300)
    allowed = MOVE * np.maximum(size, floor)
    if old.size > 1:
        gaps = np.abs(old[:, None] - old[None, :])
        np.fill_diagonal(gaps, np.inf)
        nearest = np.min(gaps, axis=1)
        allowed = np.where(nearest > 0, np.minimum(allowed, SEPARATE * nearest), allowed)
    return np.maximum(allowed, NOISE_MOVE * np.maximum(size, floor))  # near-coincident roots that stay so


def _crossings(roots_at: Callable[[float], NDArray], values: NDArray, rows: NDArray) -> tuple[Crossing, ...]:
    """Every strict sign change of Re along a branch, refined by brentq on the
    parameter (the pole followed: the root nearest the branch's chord)."""
    out = []
    re = rows.real
    for i, j in zip(*np.nonzero(np.sign(re[:-1]) * np.sign(re[1:]) < 0)):
        a, b, pa, pb = float(values[i]), float(values[i + 1]), rows[i, j], rows[i + 1, j]
        if pa.imag < 0 and pb.imag < 0:
            continue  # the conjugate of a crossing listed with its upper-half-plane twin

        def pole(v: float, a=a, b=b, pa=pa, pb=pb) -> complex:
            guess = pa + (pb - pa) * (v - a) / (b - a)
            roots = roots_at(v)
            return complex(roots[np.argmin(np.abs(roots - guess))])

        try:
            v = brentq(lambda x: pole(x).real, a, b, xtol=1e-300, maxiter=200)
        except (ValueError, RuntimeError, EngineError):
            continue  # the followed pole jumped (another one came closer): not a clean crossing
        s = pole(v)
        out.append(Crossing(float(v), abs(s.imag), complex(0.0, s.imag), 1 if pb.real > 0 else -1))
    return tuple(sorted(out, key=lambda c: (c.value, c.frequency)))


def _loop_form(network: Network, break_at: str, params: Mapping[str, float]) -> tuple[ZpkEvaluator, list[str]]:
    """The loop's pole-zero form (for asymptotes, breakaways and the map):
    `engine.loop.pole_zero`'s when it matches the network, else the same form unchecked, with a note."""
    if not network.rational:
        raise EngineError("a pole-zero map needs a rational loop (no delays, no tables)")
    loop = design(network, params).loop(break_at)
    exact, form = loop.evaluator, loop.pole_zero
    if form is not None:
        return form, []
    ss = loop.realization
    k = network.signal(break_at)
    A, B, C, D = ss.A, ss.B[:, -1:], -ss.C[k : k + 1], -ss.D[k : k + 1, -1:]
    if A.shape[0] == 0:
        raise EngineError(f"the loop broken at {break_at!r} has no dynamics: no locus")
    pencil, mass = np.block([[A, B], [C, D]]), np.zeros((A.shape[0] + 1,) * 2)
    mass[:-1, :-1] = np.eye(A.shape[0])
    with np.errstate(all="ignore"):
        zeros = linalg.eigvals(pencil, mass)
    unit = ZpkEvaluator(1.0, zeros[np.isfinite(zeros)], linalg.eigvals(A))
    at = np.array([_scale(unit)])
    gain = complex(exact(at)[0][0] / unit(at)[0][0])
    return ZpkEvaluator(complex(gain.real, 0.0), unit.zeros, unit.poles), [
        "the loop's pole-zero form differs from the network beyond 1e-9: asymptotes and breakaway points "
        "are approximate (the locus itself is polished on the network; drawn, on this form)"
    ]


def _gain_eigenvalues(network: Network, break_at: str, params: Mapping[str, float]) -> Callable[[float], NDArray]:
    """k -> the closed-loop poles with the loop gain multiplied by k: the
    eigenvalues of A - k B (1 + k D)^-1 C (to polish: `engine.closed_loop.characteristic`)."""
    ss = design(network, params).loop(break_at).realization
    b = network.signal(break_at)
    A, B, C, D = ss.A, ss.B[:, -1:], -ss.C[b : b + 1], -ss.D[b : b + 1, -1:]

    def roots(k: float) -> NDArray:
        through = 1.0 + k * D[0, 0]
        if abs(through) <= 1e-14 * max(1.0, abs(k * D[0, 0])):
            raise EngineError(f"the loop is algebraically singular at k = {k:.6g} (1 + k L(inf) = 0)")
        return np.linalg.eigvals(A - (k / through) * (B @ C))

    return roots


def _gain_range(network: Network, break_at: str, params: Mapping[str, float]) -> tuple[float, float]:
    """1e-3..1e3 times the span of 1 and the gain margins' factors (where the locus crosses)."""
    found = margins(loop_model(network, break_at, np.geomspace(1e-3, 1e3, 8), params))
    gains = [1.0] + [10 ** (m.gain_db / 20) for m in found.gain if m.gain_db is not None and math.isfinite(m.gain_db)]
    return min(gains) * 10**-GAIN_DECADES, max(gains) * 10**GAIN_DECADES


def _scale(form: ZpkEvaluator) -> float:
    roots = np.abs(np.concatenate([form.zeros, form.poles]))
    roots = roots[roots > 0]
    return float(np.exp(np.mean(np.log(roots)))) if roots.size else 1.0


def _asymptotes(form: ZpkEvaluator) -> tuple[float | None, tuple[float, ...]]:
    """Centroid (sum p - sum z)/(n - m) and angles of the n - m asymptotes
    ((2q + 1) 180/(n - m) deg for a positive loop gain, 2q 180/(n - m) for a negative one)."""
    excess = form.poles.size - form.zeros.size
    if excess <= 0:
        return None, ()
    centroid = float((np.sum(form.poles) - np.sum(form.zeros)).real / excess)
    odd = 1 if form.gain.real > 0 else 0
    return centroid, tuple(float((2 * q + odd) * 180.0 / excess) for q in range(excess))


def _breakaways(form: ZpkEvaluator) -> tuple[tuple[complex, float], ...]:
    """Points where dk/ds = 0 (roots of N'D - N D', Newton-polished on L'/L)
    with k = -1/L(s) real and positive: (point, gain)."""
    num, den = np.poly(form.zeros) if form.zeros.size else np.ones(1), np.poly(form.poles)
    q = np.polysub(np.polymul(np.polyder(num), den) if num.size > 1 else np.zeros(1), np.polymul(num, np.polyder(den)))
    q = np.trim_zeros(np.real_if_close(q), "f")
    if q.size <= 1:
        return ()
    s = np.roots(q).astype(complex)
    with np.errstate(all="ignore"):
        for _ in range(8):
            terms = form.product.terms(s, curvature=True)
            step = terms.slope / terms.curvature
            s = s - np.where(np.isfinite(step), step, 0.0)
        k = -1.0 / form.product.terms(s).value
    out = []
    for point, gain in zip(s.tolist(), k.tolist()):
        if np.isfinite(gain) and gain.real > 0 and abs(gain.imag) <= 1e-8 * abs(gain):
            point = complex(point.real, 0.0) if abs(point.imag) <= 1e-12 * abs(point) else point
            if point.imag >= 0:
                out.append((point, float(gain.real)))
    return tuple(sorted(out, key=lambda p: p[1]))

"""Roots of a network's characteristic equation polished: the closed-loop poles
of a design (`engine.closed_loop.poles`) and the points of a gain locus (`engine.closed_loop.root_locus`).

Eigenvalues are as accurate as their conditioning allows, and digits go where
roots cluster near the origin or where the state matrix is huge (a gain locus
at large gains).  With every use of the break signal scaled by the loop gain k
(none: no break), the closed-loop poles are the roots of

    F_k(s) = prod_i d_i(s) * det(I - G_k(s))

(blocks b_i = n_i/d_i; G_k(s)[row, col]: their transfer functions as
`Network.entries` place them), whose logarithmic derivative F'/F = sum over
the blocks' poles 1/(s - p) - trace((I - G_k)^-1 G_k') and size log|F| are
evaluated at complex s to rounding, block by block (`GainCharacteristic`).
That costs ~1 ms an evaluation (the blocks' expressions); a locus drawn on
screen polishes (where its eigenvalues are noisy: `engine.closed_loop.root_locus`) on the
loop's pole-zero form L instead, F_k = prod(s - p) (1 + k L(s)): a few numpy
operations (`FormCharacteristic`).

Aberth's iteration on F'/F refines every eigenvalue at once (`engine.numerics.aberth`,
with its one stopping rule: 4 ulp, or a correction below 1e-11 that no longer halves,
F's evaluation noise).

Clusters.  Where branches meet (a breakaway point) two roots nearly
coincide, and the eigenvalues, accurate to ~sqrt(eps) there, are as often as
not on the wrong side of the real axis: a real pair where the roots are a
conjugate pair, or the reverse.  Aberth's iteration cannot cross the axis: F
is real, so real starts stay real and conjugate starts stay conjugate; it
stalls about the two roots' midpoint, at a backward error ~ |k - k_b| / k_b.
So every tight cluster (`CLUSTER`) is solved as a unit from its power sums:
on a circle about the cluster's centre c that holds it alone, the contour
integral of (z - c)^p F'/F dz / (2 pi i) is the sum of (root - c)^p over the
roots inside, which the trapezoid rule on `NODES` points gets to rounding
(its error falls as (spread / radius)^NODES and (radius / gap)^NODES), and
Newton's identities turn p = 1..m into the monic factor whose roots they
are.  F is sampled only where it is not small, so these roots' backward
error is F's evaluation error (~eps) whatever the start was.

Stalled roots.  The same trap away from any cluster: where the eigenvalues
are far off (at large gains, where |A - k B C| is huge) a real pair can
stand for a conjugate pair of roots, and never converges.  Roots still moving
when the iterations run out are restarted once, moved by their last correction
diagonally (all the same way: the symmetry broken, and any mirror symmetry
about a vertical line too: on Re s = -2, (s + 2)^2 + d is real, and a
conjugate pair -2 +- i y for real roots -2 +- sqrt(-d) stays on it).

Each root, and each cluster as a unit, finally keeps whichever of the start,
Aberth's point, the cluster's and the restart's has the smallest |F_k| (the
same polynomial at the same gain: the same scale), so polishing never makes a
point worse.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import NDArray

from engine.errors import EngineError
from engine.loop.design import design
from engine.loop.pole_zero import ZpkEvaluator
from engine.model.network import Network
from engine.model.paired_product import log_modulus_sum, reciprocal_sum
from engine.numerics.aberth import aberth, aberth_step
from engine.numerics.iteration import Status

Roots = NDArray[np.complex128]
Ratio = Callable[[Roots], Roots]  # s -> F'(s)/F(s)
Size = Callable[[Roots], NDArray[np.float64]]  # s -> log|F(s)| (up to a constant)

# a cluster: members within CLUSTER of its scale, the distance from their centre to every other
# root and to the origin; its circle: RADIUS of that scale.  Inside, spread / radius <= 0.1 (0.3
# if the start was off by 3x); outside, radius / distance <= 0.1; on NODES points the trapezoid
# errors are 0.3^32 ~ 2e-17 of the sums.  Not beyond 0.1 of the centre's size: F's evaluation
# error grows with |s| (~ sum |f_i| |s|^i), and the roots' backward error with it.
CLUSTER = 0.01
RADIUS = 0.1
NODES = 32
MAX_CLUSTER = 4
ORIGIN_CLUSTER = 8  # roots about the origin: a type-k loop's k (`clusters`)
ORIGIN_GAP = 1e-6  # ... when they are this much smaller than the next root
TINY = 1e-280  # a root this small is at the origin to the floating-point range
ROUNDS = 64  # circles about one cluster, each shrunk to its roots (`cluster_roots`)
COUNT = 1e-3  # the circle's root count (sum p = 0) must be the members' count to this


class Characteristic:
    """F_k'/F_k and log|F_k| (`ratio`, `log_size`: the subclasses) for F_k = prod(s - p) R_k(s)
    over ``poles`` p (None: unusable, no polish), and the roots polished on them."""

    poles: Roots | None = None

    def ratio(self, s: Roots, k: float) -> Roots:
        raise NotImplementedError

    def log_size(self, s: Roots, k: float) -> NDArray[np.float64]:
        raise NotImplementedError

    def polish(self, k: float, eig: Roots, quiet: NDArray[np.float64] | None = None) -> Roots:
        """The roots near ``eig`` at gain k, in its order (``eig`` itself if unusable: no poles,
        or as many as ``eig`` has not); ``quiet`` (per root): ``eig`` itself where Aberth's
        first correction moves no root by more (one evaluation of F'/F: a cheap check)."""
        if self.poles is None or self.poles.size != eig.size or eig.size == 0:
            return eig
        ratio = lambda z: self.ratio(z, k)  # noqa: E731
        if quiet is not None:
            with np.errstate(all="ignore"):
                step = aberth_step(ratio, eig)  # not finite: on a root exactly, it stays (`aberth`)
                if np.all(np.where(np.isfinite(step), np.abs(step), 0.0) <= quiet):
                    return eig
        return refine(ratio, lambda z: self.log_size(z, k), eig)


class GainCharacteristic(Characteristic):
    """The network's F_k with the loop broken at ``break_at`` (None: F itself, no gain), over
    the blocks' poles (module docstring)."""

    def __init__(self, network: Network, break_at: str | None, params: Mapping[str, float]) -> None:
        try:
            self.poles = design(network, params).block_poles
            self.compiled = [(e.row, e.col, e.transfer.compile(params)) for e in network.entries]
        except EngineError:  # a block without a usable rational form: nothing to polish against
            self.poles, self.compiled = None, []
        self.n = len(network.signals)
        self.b = network.signal(break_at) if break_at is not None else None

    def _matrices(self, s: Roots, k: float) -> tuple[NDArray, NDArray]:
        """I - G_k(s) and G_k'(s) per point."""
        G = np.zeros((s.size, self.n, self.n), dtype=complex)
        dG = np.zeros_like(G)
        for row, col, fun in self.compiled:
            value, slope = fun(s)
            scale = k if col == self.b else 1.0
            G[:, row, col] += scale * value
            dG[:, row, col] += scale * slope
        return np.eye(self.n)[None] - G, dG

    def ratio(self, s: Roots, k: float) -> Roots:
        M, dG = self._matrices(s, k)
        return reciprocal_sum(s, self.poles) - _traces(M, dG)

    def backward_errors(self, s: Roots, k: float = 1.0) -> NDArray[np.float64]:
        """Per point, the smallest relative change of the entries of M = I - G_k(s) and of s
        itself that makes s an exact root of F_k = prod(s - p) det M (to first order:
        det(M + E) = det M (1 + trace(M^-1 E))): 1 / (sum |M_ij| |M^-1_ji| + |s| |F'/F|).  For
        a unity-feedback loop it is |1 + L| / (2 (1 + |L|)), |D + KN| / (|D| + |KN|) halved,
        with the rounding of s allowed for (a root within eps of a block pole).  0 on a block
        pole exactly, at a singular M, and below TINY (the origin, to the floating-point range)."""
        with np.errstate(all="ignore"):
            M, dG = self._matrices(s, k)
            out = np.zeros(s.size)
            usable = np.all(np.isfinite(M), axis=(1, 2)) & np.all(np.isfinite(dG), axis=(1, 2)) & (np.abs(s) > TINY)
            for i in np.flatnonzero(usable).tolist():
                try:
                    inverse = np.linalg.inv(M[i])
                except np.linalg.LinAlgError:
                    continue
                slope = reciprocal_sum(s[i : i + 1], self.poles)[0] - np.trace(inverse @ dG[i])  # F'/F
                terms = np.sum(np.abs(M[i]) * np.abs(inverse.T)) + abs(s[i]) * abs(slope)
                out[i] = 1.0 / terms if np.isfinite(terms) else 0.0
            return out

    def log_size(self, s: Roots, k: float) -> NDArray[np.float64]:
        """On a block pole exactly (0 * inf), at the next floating-point number: where Aberth's
        iteration lands when the root is there to rounding (a gain of 1e-33 moves a pole by
        1e-100), |F| is then as small as any representable point makes it."""
        s = np.where(np.isin(s, self.poles), s + np.maximum(np.abs(s) * 2.0**-52, 5e-324), s)
        with np.errstate(all="ignore"):  # NaN on a block pole (k = 0): not measurable
            M, _ = self._matrices(s, k)
            return log_modulus_sum(s, self.poles) + np.linalg.slogdet(M)[1]


class FormCharacteristic(Characteristic):
    """F_k = prod(s - p) (1 + k L(s)) from the loop's pole-zero form L (module docstring): the
    network's roots to the form's accuracy (exact to rounding for a cascade of blocks, else
    to its check, `engine.loop.pole_zero`); an improper form: no polish."""

    def __init__(self, form: ZpkEvaluator) -> None:
        self.form = form
        self.poles = form.poles if form.zeros.size <= form.poles.size else None

    def ratio(self, s: Roots, k: float) -> Roots:
        with np.errstate(all="ignore"):
            terms = self.form.product.terms(s)
            kl = k * terms.value
            return reciprocal_sum(s, self.form.poles) + kl * terms.slope / (1.0 + kl)  # F'/F = P'/P + k L'/(1 + k L)

    def log_size(self, s: Roots, k: float) -> NDArray[np.float64]:
        with np.errstate(all="ignore"):
            return log_modulus_sum(s, self.form.poles) + np.log(np.abs(1.0 + k * self.form.product.terms(s).value))


def _traces(M: NDArray, dG: NDArray) -> Roots:
    """trace(M^-1 dG) per point; infinite where M is singular (the point is a
    root of det(I - G): its Newton step is 0)."""
    try:
        return np.trace(np.linalg.solve(M, dG), axis1=1, axis2=2)
    except np.linalg.LinAlgError:
        out = np.empty(M.shape[0], dtype=complex)
        for k in range(M.shape[0]):
            try:
                out[k] = np.trace(np.linalg.solve(M[k], dG[k]))
            except np.linalg.LinAlgError:
                out[k] = np.inf
        return out


def refine(ratio: Ratio, log_size: Size, start: Roots) -> Roots:
    """The roots near ``start`` (in its order): Aberth's, tight clusters solved as units,
    stalled roots restarted off the real axis, each root kept from the candidate with
    the smallest |F| (module docstring)."""
    start = np.asarray(start, dtype=complex)
    first = aberth(ratio, start)
    polished, stalled, steps = first.roots, first.status == Status.ROUNDS, first.steps
    origin = _origin_cluster(polished)
    clustered, groups = polished.copy(), clusters(polished, origin)
    for members in groups:
        roots = cluster_roots(ratio, polished, members, origin is not None and np.array_equal(members, origin))
        if roots is not None:
            clustered[members], stalled[members] = roots, False
    candidates = [clustered, polished, start]
    if stalled.any():
        # the same trap away from a cluster (noisy eigenvalues at large gains: a real pair where
        # the roots are complex): restarted diagonally off it by their last correction (module docstring)
        kicked = clustered + np.where(stalled, (1 + 1j) * np.abs(steps), 0.0)
        candidates.insert(0, aberth(ratio, kicked).roots)
    best = _smallest(log_size, candidates, groups)
    best = np.where(np.abs(best.imag) <= 1e-14 * np.abs(best), best.real + 0j, best)
    return conjugate_pairs(ratio, best)


def conjugate_pairs(ratio: Ratio, z: Roots) -> Roots:
    """The roots of a real F in exact conjugate pairs: each complex root matched with the
    nearest mirror image of another (greedily, nearest first) or, nearer its own mirror
    than any other's, moved onto the real axis (a complex root without a partner stands
    for a real one); the moved roots are refined again, the pairs averaged."""
    if _mirrored(z):
        return z
    partner = _mirror_matching(z)
    moved = np.where(partner == np.arange(z.size), z.real + 0j, z)
    moved = _averaged(moved, partner)
    again = aberth(ratio, moved).roots
    again = np.where(partner == np.arange(z.size), again.real + 0j, again)
    return _averaged(again, partner)


def _mirrored(z: Roots) -> bool:
    """Is every complex root's conjugate among the roots, exactly?"""
    complex_roots = z[z.imag != 0]
    return bool(np.array_equal(np.sort_complex(complex_roots), np.sort_complex(complex_roots.conj())))


def _mirror_matching(z: Roots) -> NDArray[np.intp]:
    """partner[i]: the root whose mirror image z_i is (i itself: a real root)."""
    cost = np.abs(z[:, None] - z.conj()[None, :])
    partner = np.full(z.size, -1, dtype=np.intp)
    for flat in np.argsort(cost, axis=None, kind="stable"):
        i, j = divmod(int(flat), z.size)
        if partner[i] < 0 and partner[j] < 0:
            partner[i], partner[j] = j, i
            if (partner >= 0).all():
                break
    return partner


def _averaged(z: Roots, partner: NDArray[np.intp]) -> Roots:
    """Each pair set to the mean of one root and its partner's mirror (upper, lower)."""
    out = z.copy()
    for i, j in enumerate(partner.tolist()):
        if i < j:
            mean = 0.5 * (z[i] + z[j].conj())
            upper = complex(mean.real, abs(mean.imag))
            out[i], out[j] = (upper, upper.conjugate()) if z[i].imag >= 0 else (upper.conjugate(), upper)
    return out


def clusters(z: Roots, about_origin: NDArray[np.intp] | None = None) -> list[NDArray[np.intp]]:
    """Disjoint groups of roots solved as units: ``about_origin`` (`_origin_cluster`: a type-k
    loop at a small gain has k roots on a tiny circle there, where the eigenvalues are off by
    eps^(1/k) of the state matrix's size and Aberth's iteration crawls), then 2..MAX_CLUSTER roots (the smallest about each root) whose
    spread about their centre is within CLUSTER of its scale (`_extent`)."""
    used, out = np.zeros(z.size, dtype=bool), []
    if about_origin is not None:
        out.append(about_origin)
        used[about_origin] = True
    for i in _seeds(z):
        if used[i]:
            continue
        order = np.argsort(np.abs(z - z[i]), kind="stable")
        for m in range(2, min(MAX_CLUSTER, z.size) + 1):
            centre, spread, gap = _extent(z, order[:m])
            if spread <= CLUSTER * gap:
                if not used[order[:m]].any():
                    out.append(np.sort(order[:m]))
                    used[order[:m]] = True
                break
    return out


def _origin_cluster(z: Roots) -> NDArray[np.intp] | None:
    """The 1..ORIGIN_CLUSTER smallest roots when they lie within ORIGIN_GAP of the next one's
    size (one root too: within eps of a block pole at the origin, Aberth's correction cancels);
    so far from the others, the circles' power sums resolve them however they lie inside."""
    order = np.argsort(np.abs(z), kind="stable")
    size = np.abs(z[order])
    for m in range(1, min(ORIGIN_CLUSTER, z.size - 1) + 1):
        if size[m - 1] <= ORIGIN_GAP * size[m]:
            return np.sort(order[:m])
    return None


def _seeds(z: Roots) -> NDArray[np.intp]:
    """The roots a cluster can be found about (the others need no search): those whose nearest
    other root is within 2.1 CLUSTER of their size, as in a cluster about z_i (holding that root,
    within twice the spread, <= 2 CLUSTER |centre|, and |centre| <= |z_i| / (1 - CLUSTER))."""
    if z.size < 2:
        return np.zeros(0, dtype=np.intp)
    gaps = np.abs(z[:, None] - z[None, :])
    np.fill_diagonal(gaps, np.inf)
    return np.flatnonzero(np.min(gaps, axis=1) <= 2.1 * CLUSTER * np.abs(z))


def _extent(z: Roots, members: NDArray[np.intp], about_origin: bool = False) -> tuple[complex, float, float]:
    """The members' centre, their largest distance from it and its scale: its distance to
    the nearest other root and to the origin.  Members ``about_origin`` (`_origin_cluster`)
    are taken about the origin itself, their scale the distance to the nearest other root."""
    centre = complex(np.mean(z[members]))
    spread = float(np.max(np.abs(z[members] - centre)))
    if about_origin:
        centre, spread = 0j, float(np.max(np.abs(z[members])))
    others = np.delete(z, members)
    gap = float(np.min(np.abs(others - centre))) if others.size else np.inf
    return centre, spread, gap if about_origin else min(gap, abs(centre))


def cluster_roots(ratio: Ratio, z: Roots, members: NDArray[np.intp], about_origin: bool = False) -> Roots | None:
    """The roots of the cluster z[members] from their power sums on a circle (module docstring),
    in the members' order; None where the first circle does not hold exactly as many roots.
    The circle shrinks about the roots found (to 1/RADIUS of their spread) while that halves it
    at least, up to ROUNDS times: a circle much wider than the roots gives their power sums
    to eps of its radius only (roots to eps^(1/m) of it)."""
    centre, spread, gap = _extent(z, members, about_origin)
    radius, found = RADIUS * gap, None
    for _ in range(ROUNDS):
        roots = _circle_roots(ratio, centre, radius, members.size)
        if roots is None:
            break
        found = roots
        centre = complex(np.mean(roots))
        spread = float(np.max(np.abs(roots - centre)))
        if about_origin:
            centre, spread = 0j, float(np.max(np.abs(roots)))
        if not (spread / RADIUS <= 0.5 * radius and spread > 1e-300):
            break
        radius = spread / RADIUS
    if found is None:
        return None
    from scipy.optimize import linear_sum_assignment  # on first use: `analyze` loads no scipy.optimize

    rows, cols = linear_sum_assignment(np.abs(z[members][:, None] - found[None, :]))
    out = np.empty(members.size, dtype=complex)
    out[rows] = found[cols]
    return out


def _circle_roots(ratio: Ratio, centre: complex, radius: float, m: int) -> Roots | None:
    """The m roots inside the circle about ``centre`` (None: it does not hold exactly m)."""
    if not (0 < radius < np.inf):
        return None
    if abs(centre.imag) <= 1e-3 * radius:  # the circle holds the conjugates too: a real factor
        centre = complex(centre.real, 0.0)
    unit = np.exp(2j * np.pi * (np.arange(NODES) + 0.5) / NODES)  # conjugate-symmetric
    with np.errstate(all="ignore"):
        values = ratio(centre + radius * unit) * (radius * unit)  # (z - c) F'/F: dz = i (z - c) dtheta
        sums = np.array([np.mean(values * unit**p) for p in range(m + 1)])  # of ((root - c)/radius)^p
    if not (np.all(np.isfinite(sums)) and abs(sums[0] - m) <= COUNT):
        return None
    polynomial = _from_power_sums(sums.real + 0j if centre.imag == 0.0 else sums)
    return centre + radius * np.roots(polynomial.real if centre.imag == 0.0 else polynomial)


def _from_power_sums(sums: Roots) -> Roots:
    """Monic polynomial (descending) whose roots have the power sums sums[1:] (Newton's identities)."""
    m = sums.size - 1
    e = [1.0 + 0j]
    for j in range(1, m + 1):
        e.append(sum((-1) ** (i - 1) * e[j - i] * sums[i] for i in range(1, j + 1)) / j)
    return np.array([(-1) ** j * e[j] for j in range(m + 1)])


def _smallest(log_size: Size, candidates: list[Roots], groups: list[NDArray[np.intp]]) -> Roots:
    """Per root (per cluster: all its members) the candidate with the smallest |F|
    (the largest over a cluster); the first where none can be measured."""
    n = candidates[0].size
    size = np.asarray(log_size(np.concatenate(candidates)), dtype=float).reshape(len(candidates), n)
    size = np.where(np.isnan(size), np.inf, size)
    choice = np.argmin(size, axis=0)
    for members in groups:
        choice[members] = np.argmin(np.max(size[:, members], axis=1))
    return np.choose(choice, candidates)

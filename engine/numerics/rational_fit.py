"""Rational fits of a tabulated open loop GH(j omega) by AAA, for margin refinement.

Why AAA.  Margins of a measured loop (crossovers, minima of |1 + GH|, maxima
of |GH|) are better refined on a smooth model than on the grid.  No maintained
library fits a rational function to frequency-response data: scipy has no AAA
or vector fitting, python-control has none.  AAA (Nakatsukasa, Sete, Trefethen,
"The AAA algorithm for rational approximation", SIAM J. Sci. Comput. 40, 2018)
is short, needs one SVD per step, chooses its own degree and copes with many
decades of frequency.

Variant (real-symmetric).  Data GH_i at z_i = j w_i, w_i > 0; conj(GH_i) at
-j w_i is implied.  Support points come in conjugate pairs (j s, -j s) with
values (f, conj f) and weights (c, conj c), plus optionally a node at infinity
with real weights (n_inf, d_inf):

    r(z) = (n_inf + sum_j w_j f_j / (z - z_j)) / (d_inf + sum_j w_j / (z - z_j)),

so r(conj z) = conj r(z) exactly (real coefficients).  k pairs give type
(2k-1, 2k-1), with the infinity node (2k, 2k): every degree 0, 1, 2, ... is
reachable.  The least squares is posed on the positive half only, as a real SVD
in (Re c, Im c, d_inf, n_inf), rows weighted by 1/|GH_i| and then twice by
1/|D(z_i)| of the last solve (Sanathanan-Koerner: the true relative error, not
the linearised one that neglects points near poles; it matters on noisy data).
The greedy step adds the pair at the largest relative error.

Residual.  `residual` = max_i |r(j w_i) - GH_i| / max(|GH_i|, 1e-13 max|GH|),
the pointwise relative error on the table (`residual_rms`: its rms).  It bounds
the margin errors at the table points: phase error <= asin(residual) rad, gain
error <= 20 log10(1 + residual) dB, error of |1 + GH| <= residual |GH|.  The
floor only matters thirteen decades below the peak (zeros of the data).

Stopping.  Degrees 0, 1, 2, ... up to `max_degree` (at most min(100, m // 2))
until the residual reaches `tolerance` or the rms has not halved over ten
degrees (thirty while it is above 0.1: a long delay needs many degrees before
the error falls).  The result is the lowest degree meeting the tolerance or with
rms <= 1.5 best + 1e3 tolerance, so ill-conditioned clean data get no dozen
extra poles for 1e-10 -> 1e-12, and noisy data are not interpolated: with noise
of relative rms eps, `residual_rms` ~ eps and `residual` ~ its maximum (2-4 eps).

Cleanup.  Froissart doublets are poles p whose nearest zero q has
|p - q| < max(1e-7, residual) * distance(p, table): they change r on the table
by less than the fit resolves.  As in the AAA paper the support pairs nearest
them are dropped (n doublets lower the degree by n) and the least squares is
solved again; of that refit and the greedy fits of lower degree, the lowest
whose residual <= max(tolerance, 1e-8, 2 x before) and rms <= max(tolerance,
1e-8, 1.25 x before) is kept (three rounds at most), else the doublets stay.
Clean data of exact degree thus trade ~1e-14 (reached with doublets) for ~1e-11
(~1e-9 with repeated poles) at the true degree, with the true poles only.

Evaluation.  `evaluate` gives r(j w) and d/dw r(j w) = j r'(j w), with
r'(z) = sum_j w_j (r(z) - f_j) / (z - z_j)^2 / D(z).  The nearest node's term is
factored out (all multiplied by z - z_k, r - f_k written without cancellation),
so at a support point the value is the data value and the derivative the exact
limit (n_inf - f_k d_inf + sum_{j != k} w_j (f_j - f_k) / (z_k - z_j)) / w_k.

Limits.  A fit is only as good as the table.  The residual is measured on the
table; between points the model is a smooth interpolation, exact only for a
rational loop (measured: 1-50 x the residual, the worst for lightly damped modes
sampled about once per bandwidth).  A delay is approximated; one with
T max(w) beyond ~100 may stall past the patience: divide a known delay out
first.  Noise is fitted down to its level, not removed.  Poles beyond
1e10 max(w) are dropped as numerically infinite.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import EngineError, GridError
from engine.numerics.point_memo import PointMemo

FLOOR = 1e-13  # |GH| below this fraction of max |GH| is measured absolutely
PATIENCE = 10  # stop after this many degrees without halving the rms ...
LONG_PATIENCE = 30  # ... or this many while the rms is still above 0.1
SPURIOUS = 1e-7  # pole-zero gap / distance to the table below this: a Froissart doublet
ACCEPT = 1e-8  # a cleanup may raise the residual up to this
SELECT_SLACK = 1.5  # the lowest degree with rms within this factor of the best ...
CONVERGED = 1e3  # ... plus this times the tolerance is kept
CLEAN_SLACK = 1.25  # a cleanup may raise the rms by this factor
FAR_POLE = 1e10  # poles beyond this times max(omega) are numerically infinite
DEGREE_CAP = 100
SK_STEPS = 2  # reweighted re-solves per degree
CHUNK = 4096  # frequencies per evaluation block

Complex = NDArray[np.complex128]


@dataclass(frozen=True, eq=False)
class RationalFit:
    """A real-coefficient rational model r of a frequency response, in barycentric form.

    `support`, `values`, `weights` hold the finite nodes in conjugate pairs
    (first j s_i, then -j s_i); `n_inf`, `d_inf` are the (real) numerator and
    denominator weights of the node at infinity (0 when unused).  `poles` are
    the finite poles of r; `residual` and `residual_rms` are the max and rms
    relative errors on the table (module doc); `degree` n is the type (n, n).
    """

    support: Complex
    values: Complex
    weights: Complex
    n_inf: float
    d_inf: float
    poles: Complex
    residual: float
    residual_rms: float
    degree: int
    seen: PointMemo = field(default_factory=PointMemo, init=False, repr=False)  # `evaluate`'s values so far

    def __post_init__(self) -> None:
        for array in (self.support, self.values, self.weights, self.poles):
            array.setflags(write=False)

    def __call__(self, omega: ArrayLike) -> Complex:
        """GH(j omega) of the model, shaped like omega."""
        return self._eval(omega, derivative=False)[0]

    def evaluate(self, omega: ArrayLike) -> tuple[Complex, Complex]:
        """(GH(j omega), dGH/domega) of the model, each shaped like omega; a frequency asked before is
        not evaluated again (`seen`: a table's fit is asked at the same frequencies on every design)."""
        return self.seen.values(np.asarray(omega, dtype=float), lambda w: self._eval(w, derivative=True))

    def _eval(self, omega: ArrayLike, derivative: bool) -> tuple[Complex, Complex]:
        """r and dr/domega in chunks of CHUNK frequencies (memory CHUNK x len(support))."""
        w = np.asarray(omega, dtype=float)
        z = 1j * w.ravel()
        r, dr = np.empty_like(z), np.empty_like(z)
        for lo in range(0, z.size, CHUNK):
            part = slice(lo, lo + CHUNK)
            r[part], dr[part] = _bary(
                z[part], self.support, self.weights, self.values, self.n_inf, self.d_inf, derivative
            )
        return r.reshape(w.shape), (1j * dr).reshape(w.shape)


def _bary(
    z: Complex, nodes: Complex, w: Complex, f: Complex, n_inf: float, d_inf: float, derivative: bool
) -> tuple[Complex, Complex]:
    """r(z) and r'(z) (or zeros), with the nearest node's term factored out."""
    if nodes.size == 0:
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.full(z.shape, np.divide(np.float64(n_inf), d_inf), dtype=complex)
        return r, np.zeros(z.shape, dtype=complex)
    delta = z[:, None] - nodes[None, :]
    rows = np.arange(z.size)
    k = np.argmin(np.abs(delta), axis=1)
    dk = delta[rows, k].copy()
    delta[rows, k] = 1.0
    with np.errstate(all="ignore"):
        c = 1.0 / delta
        c[rows, k] = 0.0
        d_rest = c @ w + d_inf
        n_rest = c @ (w * f) + n_inf
        wk, fk = w[k], f[k]
        den = wk + dk * d_rest  # = (z - z_k) D(z)
        r = np.where(dk == 0.0, fk, (wk * fk + dk * n_rest) / den)
        if not derivative:
            return r, np.zeros(z.shape, dtype=complex)
        g = (n_rest - fk * d_rest) / den  # = (r - f_k) / (z - z_k)
        s_rest = (c * c * (r[:, None] - f[None, :])) @ w
        return r, (wk * g + dk * s_rest) / den


def _poles(nodes: Complex, w: Complex, d_inf: float) -> Complex:
    """Zeros of the barycentric denominator (arrowhead generalised eigenproblem)."""
    n = nodes.size
    if n == 0:
        return np.empty(0, dtype=complex)
    e = np.zeros((n + 1, n + 1), dtype=complex)
    e[0, 0], e[0, 1:], e[1:, 0] = d_inf, w, 1.0
    e[1:, 1:] = np.diag(nodes)
    import scipy.linalg  # on first use (start-up)

    try:
        lam = scipy.linalg.eigvals(e, np.diag(np.r_[0.0, np.ones(n)]))
    except (np.linalg.LinAlgError, ValueError):
        return np.empty(0, dtype=complex)
    keep = np.isfinite(lam) & (np.abs(lam) <= FAR_POLE * np.max(np.abs(nodes)))
    return np.sort_complex(lam[keep])


@dataclass(frozen=True)
class _Step:
    """One least-squares fit during the AAA iteration (normalised data)."""

    idx: NDArray[np.int_]  # table indices of the support pairs
    use_inf: bool
    nodes: Complex
    w: Complex
    f: Complex
    n_inf: float
    d_inf: float
    err: NDArray[np.float64]  # relative error at each table point

    @property
    def residual(self) -> float:
        return float(self.err.max())

    @property
    def rms(self) -> float:
        with np.errstate(over="ignore"):
            return float(np.sqrt(np.mean(self.err**2)))

    @property
    def degree(self) -> int:
        return 2 * self.idx.size - 1 + int(self.use_inf)


def _relative_error(r: Complex, f: Complex, scale: NDArray[np.float64]) -> NDArray[np.float64]:
    """|r - f| / scale, with inf where r is not finite."""
    with np.errstate(all="ignore"):
        err = np.abs(r - f) / scale
    return np.where(np.isfinite(err), err, np.inf)


def _null_vector(a: Complex, row_weight: NDArray[np.float64]) -> NDArray[np.float64]:
    """Real unit vector v minimising |diag(row_weight) a v| (columns balanced first)."""
    m = a * row_weight[:, None]
    m = np.vstack([m.real, m.imag])
    norms = np.linalg.norm(m, axis=0)
    top = norms.max() if norms.size and norms.max() > 0.0 else 1.0
    norms[norms <= 1e-13 * top] = top  # a column of rounding noise stays negligible
    m = m / norms
    if m.shape[0] > m.shape[1]:
        m = np.linalg.qr(m, mode="r")  # same right singular vectors, much cheaper SVD
    return np.linalg.svd(m)[2][-1] / norms


def _solve(z: Complex, f: Complex, scale: NDArray[np.float64], idx: NDArray[np.int_], use_inf: bool) -> _Step:
    """Barycentric weights for support pairs `idx`: rows weighted 1 / |GH_i|, then
    (Sanathanan-Koerner) 1 / |GH_i D(z_i)| with D of the last solve; the best try."""
    rest = np.setdiff1d(np.arange(z.size), idx)
    zr, fr = z[rest, None], f[rest, None]
    zs, fs = z[idx], f[idx]
    cauchy = np.hstack([1.0 / (zr - zs), 1.0 / (zr - zs.conj())])
    c1, c2 = (fr - fs) * cauchy[:, : idx.size], (fr - fs.conj()) * cauchy[:, idx.size :]
    a = np.hstack([c1 + c2, 1j * (c1 - c2)] + ([fr, -np.ones_like(fr)] if use_inf else []))
    nodes = np.concatenate([zs, zs.conj()])
    vals = np.concatenate([fs, fs.conj()])
    row_weight = 1.0 / scale[rest]
    tried: list[_Step] = []
    for _ in range(1 + SK_STEPS):
        v = _null_vector(a, row_weight)
        c = v[: idx.size] + 1j * v[idx.size : 2 * idx.size]
        d_inf, n_inf = (float(v[-2]), float(v[-1])) if use_inf else (0.0, 0.0)
        w = np.concatenate([c, c.conj()])
        r, _ = _bary(z, nodes, w, vals, n_inf, d_inf, derivative=False)
        tried.append(_Step(idx, use_inf, nodes, w, vals, n_inf, d_inf, _relative_error(r, f, scale)))
        den = np.abs(cauchy @ w + d_inf)
        if not np.all(np.isfinite(den) & (den > 0.0)):
            break
        row_weight = 1.0 / (scale[rest] * den)
        row_weight /= row_weight.max()
    return min(tried, key=lambda s: s.residual)


def _check(omega: ArrayLike, gh: ArrayLike) -> tuple[NDArray[np.float64], Complex]:
    """The table as float and complex arrays, or an EngineError saying what is wrong."""
    try:
        if np.iscomplexobj(omega):
            raise TypeError("omega is complex")
        w = np.asarray(omega, dtype=float)
        f = np.asarray(gh, dtype=complex)
    except (TypeError, ValueError) as exc:
        raise EngineError(f"fit_response: omega must be real and gh numeric ({exc})") from None
    if w.ndim != 1 or f.shape != w.shape:
        raise EngineError(f"fit_response: omega and gh must be 1-D of equal length, got shapes {w.shape} and {f.shape}")
    if w.size < 4:
        raise EngineError(f"fit_response: need at least 4 points, got {w.size}")
    if not np.all(np.isfinite(w)):
        raise GridError(f"fit_response: non-finite omega at index {np.flatnonzero(~np.isfinite(w))[0]}")
    if w[0] <= 0.0:
        raise GridError(f"fit_response: omega must be positive, omega[0] = {w[0]}")
    if np.any(np.diff(w) <= 0.0):
        bad = np.flatnonzero(np.diff(w) <= 0.0)[0]
        raise GridError(f"fit_response: omega not strictly increasing at index {bad + 1}")
    if not np.all(np.isfinite(f)):
        raise EngineError(
            f"fit_response: non-finite gh at index {np.flatnonzero(~np.isfinite(f))[0]}"
            f" (omega = {w[~np.isfinite(f)][0]})"
        )
    return w, f


def _degree_cap(m: int, tolerance: float, max_degree: int | None) -> int:
    """min(100, m // 2, max_degree), after checking tolerance and max_degree."""
    if not (np.isfinite(tolerance) and tolerance >= 0.0):
        raise EngineError(f"fit_response: tolerance must be finite and >= 0, got {tolerance}")
    if max_degree is not None and (not isinstance(max_degree, (int, np.integer)) or max_degree < 0):
        raise EngineError(f"fit_response: max_degree must be a whole number >= 0, got {max_degree}")
    return min(DEGREE_CAP, m // 2, DEGREE_CAP if max_degree is None else int(max_degree))


def _iterate(z: Complex, f: Complex, scale: NDArray[np.float64], tolerance: float, cap: int) -> list[_Step]:
    """AAA fits of degree 0, 1, 2, ... until the tolerance, the cap or stagnation."""
    steps: list[_Step] = []
    idx = np.empty(0, dtype=int)
    mark_res, mark_deg, nxt = np.inf, 0, 0
    for n in range(cap + 1):
        if n % 2 == 1:
            idx = np.append(idx, nxt)
        try:
            step = _solve(z, f, scale, idx, use_inf=(n % 2 == 0))
        except np.linalg.LinAlgError:
            break
        steps.append(step)
        if step.residual <= tolerance:
            break
        if step.rms < 0.5 * mark_res:
            mark_res, mark_deg = step.rms, n
        elif n - mark_deg >= (PATIENCE if step.rms < 0.1 else LONG_PATIENCE):
            break
        err = step.err.copy()
        err[idx] = -1.0
        nxt = int(np.argmax(err))
    return steps


def _doublets(z: Complex, step: _Step) -> Complex:
    """Poles p whose nearest zero q has |p - q| < max(SPURIOUS, residual) * distance(p, table)."""
    p = _poles(step.nodes, step.w, step.d_inf)
    q = _poles(step.nodes, step.w * step.f, step.n_inf)
    if p.size == 0 or q.size == 0:
        return np.empty(0, dtype=complex)
    gap = np.min(np.abs(p[:, None] - q[None, :]), axis=1)
    far = np.min(np.abs((p.real + 1j * np.abs(p.imag))[:, None] - z[None, :]), axis=1)
    bad = gap < max(SPURIOUS, step.residual) * far
    return p[bad][np.argsort(gap[bad] / far[bad])]


def _cleanup(
    z: Complex, f: Complex, scale: NDArray[np.float64], steps: list[_Step], step: _Step, tolerance: float
) -> _Step:
    """Remove Froissart doublets: drop the nearest support pairs and re-solve (AAA paper).

    n doublets lower the degree by n (a pair is two degrees, the infinity node one).
    The refit or a greedy fit of lower degree replaces `step` if neither its
    residual nor its rms is worse than the module doc allows.
    """
    first = step
    for _ in range(3):
        bad = _doublets(z, step)
        if bad.size == 0:
            return step
        target = max(step.degree - bad.size, 0)
        k_new, use_inf = (target + 1) // 2, target % 2 == 0
        near = np.argmin(np.abs(bad[:, None] - step.nodes[None, :]), axis=1) % step.idx.size
        order = list(dict.fromkeys(list(near) + list(range(step.idx.size - 1, -1, -1))))
        idx = np.delete(step.idx, order[: step.idx.size - k_new])
        candidates = [s for s in steps if s.degree < step.degree]
        try:
            candidates.append(_solve(z, f, scale, idx, use_inf))
        except np.linalg.LinAlgError:
            pass
        floor = max(tolerance, ACCEPT)
        good = [
            s
            for s in candidates
            if s.residual <= max(floor, 2.0 * first.residual) and s.rms <= max(floor, CLEAN_SLACK * first.rms)
        ]
        if not good:
            return step
        step = min(good, key=lambda s: (s.degree, s.residual))
    return step


def fit_response(
    omega: ArrayLike, gh: ArrayLike, tolerance: float = 1e-12, max_degree: int | None = None
) -> RationalFit:
    """Fit a real-coefficient rational model to GH(j omega_i) by AAA (see module doc).

    `tolerance` is the target relative residual; `max_degree` is capped at
    min(100, len(omega) // 2), which is also the default.
    """
    w, f = _check(omega, gh)
    cap = _degree_cap(w.size, tolerance, max_degree)
    peak = float(np.max(np.abs(f)))
    empty = np.empty(0, dtype=complex)
    if peak == 0.0:
        return RationalFit(empty, empty.copy(), empty.copy(), 0.0, 1.0, empty.copy(), 0.0, 0.0, 0)
    if peak < np.finfo(float).tiny:
        raise EngineError(
            f"the tabulated response peaks at {peak:.3g}, below the smallest normal float: "
            "it cannot be fitted (check the table's gain)"
        )
    w_ref = float(np.sqrt(w[0]) * np.sqrt(w[-1]))  # fit in s / w_ref and f / peak
    z, fn = 1j * (w / w_ref), f / peak
    scale = np.maximum(np.abs(fn), FLOOR)
    steps = _iterate(z, fn, scale, tolerance, cap)
    if not steps:  # the SVD failed at once: fall back on the mean real value
        with np.errstate(all="ignore"):  # an overflowing table: its residuals are not finite (refused below)
            mean = float(np.mean(fn.real))
            steps = [_Step(np.empty(0, int), True, empty, empty, empty, mean, 1.0, abs(mean - fn) / scale)]
    steps = [s for s in steps if np.isfinite(s.rms)]
    if not steps:  # a table with overflowing or non-finite values
        raise EngineError("the tabulated response cannot be fitted: its residuals are not finite")
    best = min(s.rms for s in steps)
    enough = SELECT_SLACK * best + CONVERGED * tolerance
    step = next((s for s in steps if s.residual <= tolerance or s.rms <= enough), min(steps, key=lambda s: s.rms))
    step = _cleanup(z, fn, scale, steps, step, tolerance)
    values = np.concatenate([f[step.idx], f[step.idx].conj()])  # exact data at support
    support, weights = 1j * np.concatenate([w[step.idx], -w[step.idx]]), step.w * w_ref
    r, _ = _bary(1j * w, support, weights, values, step.n_inf * peak, step.d_inf, False)
    final = replace(step, err=_relative_error(r, f, scale * peak))
    return RationalFit(
        support=support,
        values=values,
        weights=weights,
        n_inf=step.n_inf * peak,
        d_inf=step.d_inf,
        poles=_poles(support, weights, step.d_inf),
        residual=final.residual,
        residual_rms=final.rms,
        degree=max(step.degree, 0),
    )


@dataclass(frozen=True)
class Trend:
    """T(s) = (s/c)^-low (1 + s/c)^(low - high): a table's asymptotes (slopes of -20 low and
    -20 high dB/decade at its ends, c the geometric middle of its range).  A table spanning
    twenty decades (a type-3 loop) is fitted as GH / T, within a few decades: a fit of GH
    itself in barycentric form cannot be relatively accurate both at its largest and at its
    smallest values (its sums cancel to eps of the largest, and `FLOOR` measures the
    smallest absolutely)."""

    low: int
    high: int
    corner: float

    @staticmethod
    def of(omega: NDArray[np.float64], gh: Complex) -> Trend:
        """The integer end slopes of log |GH| over log omega (the first and last twentieth
        of the table, at least three points)."""
        n = max(3, omega.size // 20)
        with np.errstate(all="ignore"):
            x, y = np.log10(omega), np.log10(np.abs(gh))

        def slope(part: slice) -> int:
            xs, ys = x[part], y[part]
            keep = np.isfinite(ys)
            if keep.sum() < 2 or np.ptp(xs[keep]) == 0:
                return 0
            return int(np.clip(np.round(-np.polyfit(xs[keep], ys[keep], 1)[0]), -MAX_TREND, MAX_TREND))

        return Trend(slope(slice(0, n)), slope(slice(-n, None)), float(np.sqrt(omega[0]) * np.sqrt(omega[-1])))

    def evaluate(self, omega: ArrayLike) -> tuple[Complex, Complex]:
        """T(j omega) and dT/domega."""
        s = 1j * np.asarray(omega, dtype=float) / self.corner
        value = s ** (-self.low) * (1.0 + s) ** (self.low - self.high)
        return value, value * 1j / self.corner * (-self.low / s + (self.low - self.high) / (1.0 + s))


MAX_TREND = 8  # end slopes beyond this many decades per decade are not asymptotes

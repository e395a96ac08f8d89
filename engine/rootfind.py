"""Vectorized bracketing root refinement (Illinois regula falsi with bisection
safeguard) for many brackets at once: each iteration evaluates the function
at all open brackets in one call, so no Python loop runs per frequency."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

EPS = np.finfo(float).eps


def refine_roots(fun: Callable[[NDArray, NDArray], NDArray], a: NDArray, b: NDArray, fa: NDArray,
                 fb: NDArray, max_iter: int = 200) -> NDArray[np.float64]:
    """Roots in brackets [a, b] with fa*fb <= 0, to machine precision.

    ``fun(points, which)`` gives the real function values at ``points`` for the
    brackets numbered ``which`` (so one call can serve different functions).
    """
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)
    fa, fb = np.array(fa, dtype=float), np.array(fb, dtype=float)
    root = np.where(fa == 0, a, np.where(fb == 0, b, np.nan))
    open_ = np.isnan(root)
    side = np.zeros(a.shape, dtype=int)
    previous = np.full(a.shape, np.nan)
    for iteration in range(max_iter):
        if not open_.any():
            break
        idx = np.flatnonzero(open_)
        ai, bi, fai, fbi = a[idx], b[idx], fa[idx], fb[idx]
        with np.errstate(all="ignore"):
            c = bi - fbi * (bi - ai) / (fbi - fai)
        mid = 0.5 * (ai + bi)
        tol = 4 * EPS * np.maximum(np.abs(ai), np.abs(bi))
        at_end = np.isfinite(c) & ((np.abs(c - ai) <= tol) | (np.abs(c - bi) <= tol))
        if at_end.any():  # the secant lands on an end: that end is the root
            ends = idx[at_end]
            root[ends] = np.where(np.abs(c[at_end] - ai[at_end]) <= tol[at_end], ai[at_end], bi[at_end])
            open_[ends] = False
            keep = ~at_end
            idx, ai, bi, fai, fbi, c, mid = idx[keep], ai[keep], bi[keep], fai[keep], fbi[keep], c[keep], mid[keep]
            if idx.size == 0:
                break
        bad = ~np.isfinite(c) | (c <= np.minimum(ai, bi)) | (c >= np.maximum(ai, bi))
        if iteration % 6 == 5:  # a bisection now and then bounds the worst case
            bad[:] = True
        c = np.where(bad, mid, c)
        fc = np.asarray(fun(c, idx), dtype=float)
        hit = fc == 0
        same_b = (np.sign(fc) == np.sign(fbi)) & ~hit
        # Illinois: halve the stale end's value when the same end is kept twice
        fai = np.where(same_b & (side[idx] == -1), fai * 0.5, fai)
        fbi = np.where(~same_b & ~hit & (side[idx] == 1), fbi * 0.5, fbi)
        new_a = np.where(same_b | hit, ai, c)
        new_b = np.where(same_b | hit, c, bi)
        a[idx], b[idx] = new_a, new_b
        fa[idx] = np.where(same_b | hit, fai, fc)
        fb[idx] = np.where(same_b | hit, fc, fbi)
        side[idx] = np.where(same_b, -1, 1)
        width = np.abs(b[idx] - a[idx])
        scale = 4 * EPS * np.maximum(np.abs(a[idx]), np.abs(b[idx]))
        settled = ~bad & (np.abs(c - previous[idx]) <= scale)  # the secant stopped moving
        previous[idx] = c
        done = hit | (width <= scale) | settled
        root[idx[done]] = np.where(hit[done] | settled[done], c[done],
                                   np.where(np.abs(fa[idx[done]]) < np.abs(fb[idx[done]]),
                                            a[idx[done]], b[idx[done]]))
        open_[idx[done]] = False
    left = np.isnan(root)
    root[left] = np.where(np.abs(fa[left]) < np.abs(fb[left]), a[left], b[left])
    return root


def sign_changes(f: NDArray, rising_only: bool = False, falling_only: bool = False) -> NDArray[np.intp]:
    """Indices i where f[i] and f[i+1] have strictly opposite signs."""
    s = np.sign(f)
    change = s[:-1] * s[1:] < 0
    if rising_only:
        change &= s[:-1] < 0
    if falling_only:
        change &= s[:-1] > 0
    return np.flatnonzero(change)

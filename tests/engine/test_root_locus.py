"""Root loci: every point of a gain locus solves D(s) + k N(s) = 0 (the loop's
own polynomials, evaluated in 40-digit mpmath), imaginary-axis crossings give
the gain margins, closed forms (Routh) for parameter loci, asymptotes and
breakaway points."""

from __future__ import annotations

import math
from collections.abc import Callable

import mpmath
import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.closed_loop.characteristic import GainCharacteristic
from engine.closed_loop.poles import polish
from engine.closed_loop.root_locus import (
    FLOOR,
    MIN_STEP,
    MOVE,
    NOISY,
    _allowed,
    continuation,
    pole_zero_map,
    root_locus,
)
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.margins.search import margins
from tests.engine.loopfactory import loop_network, random_loop
from tests.engine.test_sensitivity import mp_poly

GRID = np.geomspace(1e-3, 1e3, 10)
mpmath.mp.dps = 40


def relative_residual(num, den, k: float, s: complex) -> float:
    """The backward error of s as a root of D + k N, in 40-digit mpmath:
    |D(s) + k N(s)| / (sum |d_i| |s|^i + k sum |n_i| |s|^i).  The loops are
    given as expanded polynomials (`loopfactory`), and evaluating those in
    double precision has exactly this error floor (~1e-16): measured against
    |D| + |k N| instead, near clustered roots no double-precision root of the
    typed polynomials could reach 1e-9."""
    z = mpmath.mpc(s.real, s.imag)
    d, n = mp_poly(den, z), mpmath.mpf(k) * mp_poly(num, z)
    size = mp_poly([abs(c) for c in den], abs(z)) + mpmath.mpf(k) * mp_poly([abs(c) for c in num], abs(z))
    return float(abs(d + n) / size)


# seed 28 has a breakaway point (-1.79641 at k = 14.5955070), and at gains 1e4..2e7 (|A - k B C| up to
# ~1e12) eigenvalues ~10 % off to wholly wrong: see the tests after this one for the mechanisms
# twenty seeds and 28 here; tests/fuzz/test_root_locus_many.py runs seeds 20..49 and more under
# `make fuzz` (a polished locus of these loops takes 1-15 s: the blocks' expressions evaluated
# point by point, `engine.closed_loop.characteristic.GainCharacteristic`)
SEEDS = [*range(20), 28]


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
def test_gain_locus_points_solve_the_characteristic_equation_and_crossings_are_gain_margins(seed):
    check_gain_locus(seed)


def check_gain_locus(seed: int) -> None:
    """Every point of the polished gain locus of `random_loop(seed)` is a root of D + k N to
    1e-9 backward error, and its imaginary-axis crossings are the loop's gain margins."""
    num, den = random_loop(seed)
    network = loop_network(num, den)
    locus = root_locus(network, "e", {})
    assert locus.status == "complete"
    assert locus.values[0] == 0.0 and np.all(np.diff(locus.values) > 0)
    rows = range(1, locus.values.size, max(1, locus.values.size // 20))  # about 20 rows, all poles each
    worst = max(
        relative_residual(num, den, float(locus.values[i]), complex(s)) for i in rows for s in locus.branches[i]
    )
    assert worst <= 1e-9
    # the current poles (k = 1) are the closed-loop poles
    assert max(relative_residual(num, den, 1.0, s) for s in locus.current) <= 1e-9
    # every imaginary-axis crossing is a gain margin (k = 1/|GH| where GH is real negative), and back
    found = margins(loop_model(network, "e", GRID, {}))
    expected = sorted((10 ** (g.gain_db / 20), g.frequency) for g in found.gain if math.isfinite(g.gain_db))
    got = sorted((c.value, c.frequency) for c in locus.crossings)
    assert len(got) == len(expected), (got, expected)
    for (k, w), (k_ref, w_ref) in zip(got, expected):
        assert k == pytest.approx(k_ref, rel=1e-9)
        assert w == pytest.approx(w_ref, rel=1e-9, abs=1e-12)


DOUBLE = ([1.0], [1.0, 4.0, 3.0])  # L = 1/((s+1)(s+3)): D + k N = (s + 2)^2 + (k - 1), a double root -2 at k = 1


@pytest.mark.parametrize("d", [1e-9, -1e-9, 1e-12, -1e-12])
def test_polish_finds_a_near_double_root_from_either_side_of_the_axis(d):
    # at k = 1 + d the roots are -2 +- sqrt(-d): a conjugate pair -2 +- i sqrt(d) for d > 0, real for
    # d < 0, q = sqrt|d| = 3.2e-5 and 1e-6 apart from -2.  Eigenvalues this close to a double root are
    # only ~sqrt(eps) accurate and may lie on the wrong side of the axis; Aberth's iteration keeps real
    # starts real and conjugate ones conjugate (F is real), so from there it stalled (about -2).  On the
    # wrong side (s + 2)^2 has the sign of d, so |D + k N| >= |d| there, a residual >= |d| / 16 (the
    # scale |s|^2 + 4 |s| + 3 + k = 16 at s ~ -2): 6e-11 and 6e-14.  Every start here (the right side,
    # the wrong side, the exact double root, 10x too far on either side) must reach residual <= 1e-15:
    # ten times the rounding of D + k N in double (~1e-16), below both.
    characteristic = GainCharacteristic(unity_feedback(["1/((s+1)*(s+3))"]), "e", {})
    _assert_near_double_found(lambda start: characteristic.polish(1.0 + d, start), d)


@pytest.mark.parametrize("d", [1e-9, -1e-9, 1e-6, -1e-6])
def test_a_designs_closed_loop_poles_near_a_double_pole_from_either_side_of_the_axis(d):
    # `engine.closed_loop.poles` (a design's closed-loop poles): 1/((s+1)(s+3)) with the gain 1 + d, closed, has
    # F = (s + 2)^2 + d, the near-double pole above.  Its own Aberth iteration returned the start where it
    # did not converge to 1e-9: from the wrong side residuals |d| / 8 (|F| = 2 |d|, scale 16: 1.3e-10 and
    # 1.3e-7), from the double root |d| / 16, from 10x too far 101 |d| / 16 (6.3e-9, 6.3e-6).  At d = -1e-6
    # the conjugate start -2 +- 1e-3 i lies on Re s = -2, where F is real: Aberth's iteration stays on that
    # line, runs out of the cluster's reach, and only a restart moved off the line as well gets out.
    # 1e-15 and 1e-2 q: as above.
    network = unity_feedback([f"{1 + d!r}/((s+1)*(s+3))"])
    _assert_near_double_found(lambda start: polish(network, {}, start), d)


def _assert_near_double_found(polished: Callable[[np.ndarray], np.ndarray], d: float) -> None:
    """The roots of (s + 2)^2 + d (D + k N of `DOUBLE` at k = 1 + d) polished from either side of the
    axis, the double root and 10x too far, to residual 1e-15 and on the right side (the tests above)."""
    k, q = 1.0 + d, math.sqrt(abs(d))
    pair, line = np.array([-2 + 1j * q, -2 - 1j * q]), np.array([-2 + q, -2 - q], dtype=complex)
    for start in (pair, line, np.array([-2.0, -2.0], dtype=complex), -2 + 10 * (pair + 2), -2 + 10 * (line + 2)):
        roots = polished(start)
        assert max(relative_residual(*DOUBLE, k, complex(s)) for s in roots) <= 1e-15, (start, roots)
        # and on the right side: the roots themselves are only as good as eps * 16 / |F'(s)| = 3.6e-15 / (2 q)
        # <= 1.8e-9 = 1.8e-3 q (F' = 2 (s + 2)), so to 1e-2 q
        expected = pair if d > 0 else line
        assert sorted(roots, key=_order) == pytest.approx(sorted(expected, key=_order), abs=1e-2 * q)
        assert d > 0 or np.all(roots.imag == 0.0)


def _order(s: complex) -> tuple[float, float]:
    return (s.imag, s.real)


def test_polish_restarts_roots_stalled_on_the_real_axis_off_it():
    # far from any cluster the same trap: at k = 5 the roots are -2 +- 2i (s^2 + 4 s + 8), and real
    # starts (as the eigenvalues at large gains can be, see seed 28) stay real under Aberth's
    # iteration; restarted off the axis they converge.  1e-15: as above.
    characteristic = GainCharacteristic(unity_feedback(["1/((s+1)*(s+3))"]), "e", {})
    for start in ([-1.5, -2.5], [-2.1, -1.9], [0.0, -5.0], [10.0, -20.0]):
        roots = characteristic.polish(5.0, np.array(start, dtype=complex))
        assert sorted(roots, key=lambda s: s.imag) == pytest.approx([-2 - 2j, -2 + 2j], rel=1e-14)
        assert max(relative_residual(*DOUBLE, 5.0, complex(s)) for s in roots) <= 1e-15


def test_continuation_judges_noisy_raw_roots_on_refined_ones():
    # raw roots with noise 0.3 (> the 0.05 |pole| = 0.05..0.2 a step may move them): judged on them
    # alone every step shrinks to the floor and the 500 points run out near t = 0; judged on the
    # refined roots where the raw ones were noisy, the locus completes (the roots move by 1 over
    # t in [0, 1]: 25 steps; 50 allows for other step rules)
    rng = np.random.default_rng(0)

    def exact(t):
        return np.array([-1.0 - t, -3.0 - t], dtype=complex)

    def noisy(t):
        return exact(t) + rng.normal(0.0, 0.3, 2)

    assert continuation(noisy, 0.0, 1.0, max_points=500)[2] == "point budget reached"
    ts, rows, status = continuation(noisy, 0.0, 1.0, max_points=500, refine=lambda t, raw: exact(t))
    assert status == "complete" and ts.size <= 50
    assert np.array_equal(rows, np.array([exact(t) for t in ts]))


@pytest.mark.slow
def test_gain_locus_where_the_eigenvalues_are_wholly_wrong():
    # random loop 62 (order 6, 4 zeros near the origin; not among the acceptance test's 50): at
    # gains ~1e6..1e9 two poles run out to ~1e8 j and the eigenvalues of the small ones, near the
    # zeros, are noise, often on the wrong side of the axis.  Before: 729 points in ~190 s, 250 jumps
    # of the small poles, 70 of the points checked here with residuals up to 1.  Now steps there are
    # judged on polished points, kept in the previous row's order: ~430 points, 1e-9 everywhere
    num, den = random_loop(62)
    locus = root_locus(loop_network(num, den), "e", {})
    assert locus.status == "complete" and locus.values.size < 1000
    # no swaps: the poles near the zeros (|s| < 1) move by a quarter of their gaps per step at most
    # (0.06 here), a swap of the pairs at +-0.116j, +-0.225j by 0.23..0.45
    small = np.abs(locus.branches[1:-1]) < 1.0
    assert np.all(np.abs(np.diff(locus.branches[1:], axis=0))[small] < 0.1)
    worst = max(
        relative_residual(num, den, float(k), complex(s))
        for k, row in zip(locus.values[1::5], locus.branches[1::5])
        for s in row
    )
    assert worst <= 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("seed", [28, 62])
def test_a_drawn_locus_is_complete_continuous_and_on_the_roots(seed):
    # the TUI draws with polished=False.  Judged on the eigenvalues alone, at large gains (|A - k B C|
    # up to 1e12) 10 % off (28: the 2000 points ran out at k ~ 1e5, residuals up to 1e-2) or wholly
    # wrong (62: residual 1, the small poles jumping between the zeros' branches).  Now eigenvalues
    # within DRAWN of the polished roots (one Aberth correction on the loop's pole-zero form) are kept,
    # the others polished: 869 and 428 points here
    num, den = random_loop(seed)
    locus = root_locus(loop_network(num, den), "e", {}, polished=False)
    assert locus.status == "complete" and locus.values.size < 1000
    # on the roots: within DRAWN of them (to first order), a residual <= n DRAWN (|s F'(s)| <= n sum
    # |f_i| |s|^i for F of degree n = 8, 6): 1e-5
    rows = range(1, locus.values.size, 5)
    assert (
        max(relative_residual(num, den, float(locus.values[i]), complex(s)) for i in rows for s in locus.branches[i])
        <= 1e-5
    )
    # continuous: a step moves no pole by more than the continuation allows (`_allowed` of the last row),
    # up to the NOISY (of that) by which a kept row may differ from the eigenvalues the step was judged
    # on, at the last row and at the new one; steps forced at the floor (MIN_STEP of the range, to the
    # rounding of t + step: where poles meet, moving ~ sqrt(step)) by no more than MOVE of the pole's
    # size (floored as `_allowed` does)
    t, branches = np.log(locus.values[1:]), locus.branches[1:]
    forced = np.diff(t) <= MIN_STEP * (t[-1] - t[0]) * 1.01
    size = np.abs(branches[:-1])
    by_size = MOVE * np.maximum(size, FLOOR * size.max(axis=1, keepdims=True))
    bound = np.where(forced[:, None], by_size, (1 + 2 * NOISY) * np.array([_allowed(row) for row in branches[:-1]]))
    assert np.all(np.abs(np.diff(branches, axis=0)) <= bound)


def test_third_order_locus_closed_forms():
    # L = 1/(s (s + 1)(s + 2)): s^3 + 3 s^2 + 2 s + k; Routh: k = 6 at w = sqrt 2;
    # asymptotes from -1 at 60, 180, 300 deg; breakaway where 3 s^2 + 6 s + 2 = 0: s = -1 + 1/sqrt 3
    locus = root_locus(unity_feedback(["1/(s*(s+1)*(s+2))"]), "e", {})
    (crossing,) = locus.crossings
    assert crossing.value == pytest.approx(6.0, rel=1e-13) and crossing.frequency == pytest.approx(
        math.sqrt(2), rel=1e-13
    )
    assert crossing.direction == 1
    assert locus.centroid == pytest.approx(-1.0, rel=1e-14) and locus.angles_deg == (60.0, 180.0, 300.0)
    ((point, gain),) = locus.breakaways
    s = -1 + 1 / math.sqrt(3)
    assert point == pytest.approx(s, rel=1e-13) and gain == pytest.approx(-s * (s + 1) * (s + 2), rel=1e-12)


def test_parameter_locus_in_a_gain_and_in_a_damping_term():
    # K/(s (s + 8)(s + 20)): s^3 + 28 s^2 + 160 s + K, Routh: K = 4480 at w = sqrt 160
    network = unity_feedback(["K/(s*(s+8)*(s+20))"])
    locus = root_locus(network, "e", {"K": 1000.0}, "K")
    (c,) = locus.crossings
    assert c.value == pytest.approx(4480.0, rel=1e-12) and c.frequency == pytest.approx(math.sqrt(160), rel=1e-12)
    assert (
        locus.current_value == 1000.0
        and locus.values[0] == pytest.approx(100.0)
        and locus.values[-1] == pytest.approx(1e4)
    )
    for i in range(0, locus.values.size, 7):
        K = locus.values[i]
        for s in locus.branches[i]:
            assert relative_residual([K], [1.0, 28.0, 160.0, 0.0], 1.0, complex(s)) <= 1e-12
    # 1/(s (s^2 + a s + 2)): s^3 + a s^2 + 2 s + 1, Routh: 2 a = 1 at w = sqrt 2
    locus = root_locus(unity_feedback(["1/(s*(s**2+a*s+2))"]), "e", {"a": 2.0}, "a")
    (c,) = locus.crossings
    assert c.value == pytest.approx(0.5, rel=1e-12) and c.frequency == pytest.approx(math.sqrt(2), rel=1e-12)
    assert c.direction == -1  # a rising: the pair leaves the right half-plane


def test_bounds_and_bad_requests_are_named():
    network = unity_feedback(["1/(s*(s+1)*(s+2))"])
    assert root_locus(network, "e", {}, max_points=5).status == "point budget reached"
    for args, match in (((), "parameter .x."), (((2.0, 1.0),), "range"), (((-1.0, 1.0),), "positive")):
        parameter = "x" if not args else "gain"
        with pytest.raises(EngineError, match=match):
            root_locus(network, "e", {}, parameter, *args)
    with pytest.raises(EngineError, match="rational"):
        root_locus(unity_feedback(["1/(s+1)*exp(-0.1*s)"]), "e", {})
    with pytest.raises(EngineError, match="points"):
        root_locus(network, "e", {}, max_points=1)


def test_continuation_shrinks_steps_where_roots_move_fast():
    # roots of s^2 - t: +-sqrt(t) move fast near t = 0 (a breakaway): the steps shrink there
    ts, rows, status = continuation(lambda t: np.roots([1.0, 0.0, -t]).astype(complex), -1.0, 1.0)
    assert status == "complete" and ts[-1] == 1.0
    steps = np.diff(ts)
    near = np.abs(ts[:-1]) < 1e-3
    assert steps[near].max() < steps[~near].max() / 100
    # branches are continuous: consecutive points of one branch stay close
    assert np.max(np.abs(np.diff(rows, axis=0))) < 0.3


def test_pole_zero_map():
    pz = pole_zero_map(unity_feedback(["2*(s+3)/(s*(s+1)*(s+4))"]), "e", {})
    assert sorted(pz.poles.real) == pytest.approx([-4.0, -1.0, 0.0], abs=1e-13)
    assert pz.zeros == pytest.approx([-3.0], rel=1e-13) and pz.gain == pytest.approx(2.0, rel=1e-13)
    # closed loop: s^3 + 5 s^2 + 6 s + 6
    assert sorted(pz.closed_loop, key=lambda z: (z.real, z.imag)) == pytest.approx(
        sorted(np.roots([1, 5, 6, 6]), key=lambda z: (z.real, z.imag)), rel=1e-13
    )

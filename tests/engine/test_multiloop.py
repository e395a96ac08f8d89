"""Several loops at once (issue 56): loop at a time and all together, against references
written here (tests/engine/multiloop_references.py) and closed forms.

The spinning satellite (a = 10, unity feedback broken at the plant inputs): Doyle's example,
section 4 of Seiler, Packard and Gahinet 2020, "An introduction to disk margins" (IEEE
Control Systems Magazine 40(5)): each loop alone is 1/s (infinite gain margin, 90 deg, disk
margin alpha = 2), while both inputs perturbed at once give alpha = 0.0997 (gain
0.905..1.105, -0.87..+0.87 dB, phase 5.71 deg) near 0.05 rad/s.

Random plants: six of orders 4-20 (2-4 loops) in every run; LOOPCRAFT_MULTILOOP_CASES more
(default 4) of orders 21-40 under the slow marker, and half as many loop-at-a-time ones."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest
from scipy import optimize

from engine.analysis import analyze, unity_feedback
from engine.errors import EngineError
from engine.multiloop.disk import GAP, LEVEL, System, certify, multi_loop_disk_margin, refined
from engine.multiloop.loops import analyze_breaks, break_loop
from engine.multiloop.plant import checked_plant, loop_at, sensitivity
from engine.multiloop.simultaneous import simultaneous
from tests.engine.multiloop_references import (
    closed_loop_abscissa,
    coarse_lower,
    loop_from_matrix,
    random_plant,
    reference_lower,
    reference_upper,
    response,
    sensitivity_response,
)

OMEGA = np.geomspace(1e-3, 1e3, 400)
MORE = int(os.environ.get("LOOPCRAFT_MULTILOOP_CASES", "4"))  # random plants of orders 21-40 beyond make test's
SLOW_CASES_LOOPS = [(200 + k, 21 + (k * 5) % 20, 2 + k % 3) for k in range(max(MORE // 2, 1))]
A_SPIN = 10.0


def satellite(a: float = A_SPIN):
    """P(s) = [[s - a^2, a (s + 1)], [-a (s + 1), s - a^2]] / (s^2 + a^2) as (A, B, C, D)."""
    return np.array([[0.0, a], [-a, 0.0]]), np.eye(2), np.array([[1.0, a], [-a, 1.0]]), np.zeros((2, 2))


def satellite_transfer(s: complex, a: float = A_SPIN) -> np.ndarray:
    return np.array([[s - a * a, a * (s + 1)], [-a * (s + 1), s - a * a]]) / (s * s + a * a)


def test_the_satellite_realization_is_its_transfer_matrix():
    w = np.array([0.1, 3.0, 47.0])
    assert np.allclose(response(*satellite(), w), [satellite_transfer(1j * x) for x in w], rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("name", ["u1", "u2"])
def test_each_satellite_loop_alone_is_an_integrator(name):
    """The loop at each input, others closed, is 1/s (from the transfer matrix: P11 - P12 P21 /
    (1 + P22)); GM infinite, PM 90 deg at 1 rad/s, disk margin 2."""
    plant = checked_plant(*satellite(), "satellite")
    m = loop_at(plant, plant.index(name))
    w = np.array([0.01, 0.5, 9.5, 333.0])
    mine = np.array([m.C @ np.linalg.solve(1j * x * np.eye(2) - m.A, m.B) + m.D for x in w])
    assert np.allclose(mine, 1.0 / (1j * w), rtol=1e-12)
    assert np.allclose(loop_from_matrix(response(*satellite(), w), plant.index(name)), 1.0 / (1j * w), rtol=1e-12)
    result = analyze(unity_feedback(["1"], state_space=break_loop(plant, name)), "e", OMEGA, {})
    assert result.margins.listed("G") == ()
    (pm,) = result.margins.phase
    assert pm.frequency == pytest.approx(1.0, rel=1e-12) and pm.phase_deg == pytest.approx(90.0, rel=1e-12)
    assert result.disk_margin.alpha == pytest.approx(2.0, rel=1e-9)


def satellite_reference(skew: float) -> tuple[float, float]:
    """(max over omega of the D-scale bound of mu(S + (skew - 1)/2 I), where): a grid of 4000
    frequencies, the optimal scale by scipy's bounded Brent at each of the best, then the
    frequency by bounded Brent (two scalar blocks: the bound is mu)."""
    a, b, c, d = satellite()

    def mu(w: float) -> float:
        m = sensitivity_response(a, b, c, d, [w], skew)[0]

        def f(t):
            return np.linalg.norm(np.diag([np.exp(t), 1.0]) @ m @ np.diag([np.exp(-t), 1.0]), 2)

        return optimize.minimize_scalar(f, bounds=(-20, 20), method="bounded", options={"xatol": 1e-12}).fun

    grid = np.geomspace(1e-3, 1e3, 4001)  # not through the poles at +-10j
    coarse = np.array([np.linalg.svd(x, compute_uv=False)[0] for x in sensitivity_response(a, b, c, d, grid, skew)])
    best = max((mu(grid[k]), k) for k in np.argsort(coarse)[::-1][:40])
    k = best[1]
    found = optimize.minimize_scalar(
        lambda w: -mu(w), bounds=(grid[max(k - 1, 0)], grid[k + 1]), method="bounded", options={"xatol": 1e-13}
    )
    return -found.fun, found.x


def test_the_satellite_multi_loop_disk_margin_is_bracketed_within_1e_6():
    plant = checked_plant(*satellite(), "satellite")
    d = multi_loop_disk_margin(plant)
    peak, where = satellite_reference(0.0)
    assert d.status == "certified" and d.gap <= GAP
    assert d.alpha_lower <= 1.0 / peak * (1 + 1e-12) and 1.0 / peak <= d.alpha_upper * (1 + 1e-9)
    assert d.alpha == pytest.approx(1.0 / peak, rel=1e-6)
    assert round(d.alpha, 5) == 0.09975  # the (and the paper's) figure
    assert d.frequency == pytest.approx(where, rel=1e-3) and round(d.frequency, 2) == 0.05
    assert d.gain_low_db == pytest.approx(-0.87, abs=0.005) and d.gain_high_db == pytest.approx(0.87, abs=0.005)
    assert d.phase_deg == pytest.approx(5.71, abs=0.005)


def test_the_satellite_perturbation_found_destabilizes_it():
    """f_i = (1 + delta_i/2)/(1 - delta_i/2) at both inputs: det(I + P(j w) F) = 0 at the worst frequency."""
    plant = checked_plant(*satellite(), "satellite")
    d = multi_loop_disk_margin(plant)
    delta = np.array(d.delta)
    assert np.allclose(np.abs(delta), d.alpha_upper, rtol=1e-12)
    f = np.diag((1 + delta / 2) / (1 - delta / 2))
    assert abs(np.linalg.det(np.eye(2) + satellite_transfer(1j * d.frequency) @ f)) < 1e-10


@pytest.mark.parametrize("skew", [-0.5, 0.5, 1.0])
def test_a_skewed_satellite_margin_matches_the_reference(skew):
    d = multi_loop_disk_margin(checked_plant(*satellite(), "satellite"), skew)
    peak, _ = satellite_reference(skew)
    assert d.status == "certified" and d.gap <= GAP
    assert d.alpha_lower <= 1.0 / peak * (1 + 1e-12) <= d.alpha_upper * (1 + 1e-9)


def test_the_certificate_refuses_a_level_below_the_peak():
    """The interval cover at gamma just above the peak's bound is certified; at 0.999 of the peak,
    the certificate must stop at a frequency where mu's bound (scipy's, here) reaches gamma."""
    plant = checked_plant(*satellite(), "satellite")
    a, b, c, d = sensitivity(plant)
    system = System(a, b, c, d - 0.5 * np.eye(2))
    peak = refined(system, 0.04)
    assert peak.low == pytest.approx(10.024937810560445, rel=1e-9)  # 1 / 0.0997512422417799, the reference's
    assert certify(system, peak.high * (1 + LEVEL), peak, time.perf_counter())[0] == "certified"
    gamma = 0.999 * peak.low
    status, _, higher = certify(system, gamma, peak, time.perf_counter())
    assert status == "higher peak"
    assert reference_upper(sensitivity_response(*satellite(), [higher])[0]) >= gamma * (1 - 1e-12)


def test_the_margin_does_not_depend_on_the_state_coordinates():
    a, b, c, d = random_plant(np.random.default_rng(11), 12, 3)
    t = 2.0 ** np.random.default_rng(12).integers(-30, 31, 12)
    scaled = multi_loop_disk_margin(checked_plant(a * t[None, :] / t[:, None], b / t[:, None], c * t, d, "scaled"))
    given = multi_loop_disk_margin(checked_plant(a, b, c, d, "given"))
    assert scaled.alpha_upper == pytest.approx(given.alpha_upper, rel=1e-9)


@pytest.mark.parametrize("states", [0, 2])
def test_a_worst_case_at_infinite_frequency_is_found_and_certified(states):
    """A plant whose feedthrough couples the loops (a static gain, or with small fast dynamics): the
    worst frequency is infinite, mu there that of (I + D)^-1 - I/2 (scipy's D-scale bound here)."""
    d = np.array([[0.2, 1.5], [-1.2, 0.1]])
    a, b, c = -5.0 * np.eye(states), 0.1 * np.eye(states)[:, :2], 0.1 * np.eye(states)[:2, :]
    found = multi_loop_disk_margin(checked_plant(a, b.reshape(states, 2), c.reshape(2, states), d, "coupled"))
    peak = reference_upper(np.linalg.inv(np.eye(2) + d) - 0.5 * np.eye(2))
    assert found.status == "certified" and found.frequency == np.inf
    assert found.alpha_lower <= 1.0 / peak * (1 + 1e-12) and found.alpha_upper == pytest.approx(1.0 / peak, rel=1e-9)


def test_an_unstable_closed_loop_has_no_multi_loop_disk_margin():
    plant = checked_plant(-np.eye(2), np.eye(2), -2.0 * np.eye(2), 0.0, "unstable")  # P = -2/(s+1) I
    d = multi_loop_disk_margin(plant)
    assert (d.alpha, d.alpha_lower, d.alpha_upper, d.status) == (0.0, 0.0, 0.0, "unstable")
    assert "not stable" in d.notes[0]


@pytest.mark.parametrize(
    ("matrices", "says"),
    [
        ((-np.eye(3), np.ones((3, 2)), np.ones((3, 3)), 0.0), "2 inputs and 3 outputs"),
        ((-np.eye(2), np.eye(2), np.eye(2), np.ones((3, 3))), "D is 3 x 3"),
        ((-np.eye(2), np.eye(2), np.eye(2), [[np.nan, 0], [0, 0]]), "not finite"),
    ],
)
def test_a_bad_plant_is_refused_with_what_is_wrong(matrices, says):
    with pytest.raises(EngineError, match=says):
        checked_plant(*matrices, "--ss bad.npz")


def test_a_loop_that_is_not_well_posed_is_refused():
    """D = -I: I + D is singular (an algebraic loop), at every break and all together."""
    plant = checked_plant(-np.eye(2), np.eye(2), np.eye(2), -np.eye(2), "algebraic")
    with pytest.raises(EngineError, match="not well posed"):
        multi_loop_disk_margin(plant)
    with pytest.raises(EngineError, match="u1: I \\+ D of the other loops is singular"):
        loop_at(plant, 0)


def test_a_bad_break_and_a_break_that_opens_no_loop_are_refused():
    plant = checked_plant(*satellite(), "satellite")
    with pytest.raises(EngineError, match="u1, u2"):
        plant.index("u3")
    decoupled = checked_plant(-np.eye(2), np.array([[1.0, 0.0], [0.0, 0.0]]), np.eye(2), 0.0, "open")
    with pytest.raises(EngineError, match="u2: the loop seen there is 0"):
        break_loop(decoupled, "u2")


def reference_crossings(a, b, c, d, i: int) -> tuple[np.ndarray, np.ndarray]:
    """(gain crossovers |L| = 1, phase crossings of the negative real axis) of the loop at input i,
    L from the transfer matrix (`loop_from_matrix`): sign changes on a dense grid refined about
    every mode, each root by Brent's method to the last bits."""
    modes = np.concatenate(
        [np.linalg.eigvals(a), np.linalg.eigvals(a - b @ np.linalg.solve(np.eye(b.shape[1]) + d, c))]
    )
    sizes = np.abs(modes[np.abs(modes) > 0])
    grid = [np.geomspace(sizes.min() / 1e3, sizes.max() * 1e3, 6000)]
    grid += [abs(p.imag) + max(abs(p.real), 1e-3 * abs(p)) * np.linspace(-4, 4, 40) for p in modes]  # not on a pole
    w = np.unique(np.concatenate(grid))
    w = w[w > 0]

    def loop(x):
        return loop_from_matrix(response(a, b, c, d, np.atleast_1d(x)), i)

    values = loop(w)

    def roots(f, keep):
        v = f(values)
        found = []
        for k in np.flatnonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0):
            root = optimize.brentq(lambda x: f(loop(x))[0], w[k], w[k + 1], xtol=1e-300, rtol=1e-15)
            if keep(loop(root)[0]):
                found.append(root)
        return np.array(found)

    gain = roots(lambda v: np.log(np.abs(v)), lambda v: True)
    phase = roots(lambda v: v.imag, lambda v: v.real < 0)
    return gain, phase, loop


def _compare_loops(seed: int, order: int, loops: int) -> int:
    rng = np.random.default_rng(seed)
    a, b, c, d = random_plant(rng, order, loops, feedthrough=seed % 3 == 1, axis=seed % 2)
    result = analyze_breaks(checked_plant(a, b, c, d, "random"), OMEGA, together=False)
    compared = 0
    for i, (name, mine) in enumerate(result.loops):
        gain, phase, loop = reference_crossings(a, b, c, d, i)
        pm = np.array(sorted(p.frequency for p in mine.margins.phase if 0 < p.frequency < np.inf))
        gm = np.array(sorted(g.frequency for g in mine.margins.listed("G") if 0 < g.frequency < np.inf))
        assert pm.size == gain.size and gm.size == phase.size, name
        assert np.allclose(pm, gain, rtol=1e-9, atol=0) and np.allclose(gm, phase, rtol=1e-9, atol=0), name
        for p in mine.margins.phase:
            if 0 < p.frequency < np.inf:
                classical = 180.0 + np.degrees(np.angle(loop(p.frequency)[0]))
                assert abs((p.phase_deg - classical + 180.0) % 360.0 - 180.0) < 1e-9 * 180.0, name
        for g in mine.margins.listed("G"):
            if 0 < g.frequency < np.inf:
                assert g.gain_db == pytest.approx(-20 * np.log10(abs(loop(g.frequency)[0])), rel=1e-9, abs=1e-9)
        compared += pm.size + gm.size
    return compared


@pytest.mark.parametrize(("seed", "order", "loops"), [(0, 4, 2), (2, 12, 3), (4, 20, 3), (5, 6, 4)])
def test_loop_at_a_time_margins_match_the_transfer_matrix_to_1e_9(seed, order, loops):
    assert _compare_loops(seed, order, loops) > 0


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "order", "loops"), SLOW_CASES_LOOPS)
def test_more_loop_at_a_time_margins_match(seed, order, loops):
    assert _compare_loops(seed, order, loops) >= 0


# --- random plants against the reference -------------------------------------------------

CASES = [
    (seed, order, loops) for seed, (order, loops) in enumerate([(4, 2), (8, 2), (12, 3), (16, 2), (20, 3), (6, 4)])
]
SLOW_CASES = [(100 + k, 21 + (k * 7) % 20, 2 + k % 3) for k in range(MORE)]


def _compare_together(seed: int, order: int, loops: int) -> None:
    rng = np.random.default_rng(seed)
    a, b, c, d = random_plant(rng, order, loops, feedthrough=seed % 3 == 1, axis=seed % 2)
    assert closed_loop_abscissa(a, b, c, d) < 0
    mine = multi_loop_disk_margin(checked_plant(a, b, c, d, "random"))
    low, where = reference_lower(a, b, c, d)  # mu >= low somewhere: alpha <= 1/low
    high = reference_upper(sensitivity_response(a, b, c, d, [where])[0])
    assert mine.alpha_lower <= (1.0 / low) * (1 + 1e-9), (
        "the certified lower bound exceeds a destabilizing perturbation"
    )
    assert max(mine.alpha_lower, 1.0 / high) <= min(mine.alpha_upper, 1.0 / low) * (1 + 1e-6), "brackets do not overlap"
    if loops <= 3:
        assert mine.status == "certified" and mine.gap <= GAP
    p = response(a, b, c, d, [mine.frequency])[0]
    delta = np.array(mine.delta)
    f = np.diag((1 + delta / 2) / (1 - delta / 2))
    assert abs(np.linalg.det(np.eye(loops) + p @ f)) < 1e-7 * max(1.0, np.abs(p).max()) ** loops


@pytest.mark.parametrize(("seed", "order", "loops"), CASES)
def test_random_plants_bracket_the_reference(seed, order, loops):
    _compare_together(seed, order, loops)


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "order", "loops"), SLOW_CASES)
def test_more_random_plants_bracket_the_reference(seed, order, loops):
    _compare_together(seed, order, loops)


# --- python-control's MIMO disk_margins (SLICOT's AB13MD on a grid), where slycot is installed ---


def _python_control_cases():
    import control as ct

    p = ct.ss([[0, 10], [-10, 0]], np.eye(2), [[1, 10], [-10, 1]], 0)
    k = ct.ss([], [], [], [[1, -2], [0, 1]])  # the example of disk_margins' docstring (as MATLAB's diskmargin)
    yield p
    yield p * k
    for seed in range(4):
        yield ct.ss(*random_plant(np.random.default_rng(300 + seed), 10, 2 + seed % 2))


@pytest.mark.slow
def test_python_control_on_a_grid_agrees_within_its_resolution():
    """On its grid python-control's alpha is the minimum of 1/mu over the grid's points, so at least
    the true alpha (for up to three loops AB13MD's bound is mu): never below our alpha_lower; with our
    worst frequency added to its grid it gives our alpha_upper."""
    pytest.importorskip("slycot")
    import control as ct

    for loop in _python_control_cases():
        mine = multi_loop_disk_margin(checked_plant(loop.A, loop.B, loop.C, loop.D, "python-control case"))
        grid = np.logspace(-3, 3, 2000)
        theirs = float(ct.disk_margins(loop, grid)[0])
        there = float(ct.disk_margins(loop, np.array([mine.frequency]))[0])
        assert mine.status == "certified"
        assert mine.alpha_lower <= theirs * (1 + 1e-9)
        assert there == pytest.approx(mine.alpha_upper, rel=1e-9)


# --- a plant in z ---------------------------------------------------------------------------


def z_reference(a, b, c, d, sample_time: float) -> float:
    """max over 0 < omega < pi/T of mu's lower bound of S(e^{j omega T}) - I/2: a dense grid, phases
    on a grid, the best three refined by Nelder-Mead over (log omega, phases)."""
    m = b.shape[1]

    def sens(w):
        z = np.exp(1j * np.atleast_1d(w) * sample_time)
        p = np.array([c @ np.linalg.solve(x * np.eye(a.shape[0]) - a, b) + d for x in z])
        return np.linalg.inv(np.eye(m) + p) - 0.5 * np.eye(m)

    omega = np.geomspace(1e-4, np.pi / sample_time * (1 - 1e-9), 4000)
    low = coarse_lower(sens(omega))
    best = 0.0
    for k in np.argsort(low)[::-1][:3]:

        def f(v):
            mat = sens(min(np.exp(v[0]), np.pi / sample_time))[0]
            return -np.abs(np.linalg.eigvals(mat * np.exp(1j * np.append(v[1:], 0.0))[None, :])).max()

        found = optimize.minimize(
            f, [np.log(omega[k]), *np.zeros(m - 1)], method="Nelder-Mead", options={"xatol": 1e-12}
        )
        best = max(best, -found.fun, low[k])
    return best


@pytest.mark.parametrize("seed", [None, 7])
def test_a_plant_in_z_is_analyzed_through_its_w_plane_form(seed):
    from scipy.signal import cont2discrete

    T = 0.01 if seed is None else 0.05
    plant = satellite() if seed is None else random_plant(np.random.default_rng(seed), 8, 2)
    a, b, c, d, _ = cont2discrete(plant, T, method="zoh")
    result = analyze_breaks(
        checked_plant(a, b, c, d, "in z"), np.geomspace(1e-3, np.pi / T * 0.999, 300), sample_time=T
    )
    together = result.together
    peak = z_reference(a, b, c, d, T)
    assert together.status == "certified" and together.gap <= GAP
    assert together.alpha_lower <= 1.0 / peak * (1 + 1e-12) and together.alpha_upper == pytest.approx(
        1.0 / peak, rel=1e-6
    )
    assert 0 <= together.frequency <= np.pi / T
    for i, (name, mine) in enumerate(result.loops):
        assert mine.margins.phase, name
        for p in mine.margins.phase:
            z = np.exp(1j * p.frequency * T)
            loop = loop_from_matrix((c @ np.linalg.solve(z * np.eye(a.shape[0]) - a, b) + d)[None], i)[0]
            assert abs(loop) == pytest.approx(1.0, rel=1e-9), name
            assert abs((p.phase_deg - 180.0 - np.degrees(np.angle(loop)) + 180.0) % 360.0 - 180.0) < 1e-7, name


# --- simultaneous gain-only and phase-only margins -------------------------------------------


def satellite_characteristic(f1: complex, f2: complex, a: float = A_SPIN) -> np.ndarray:
    """Roots of det(sI - A + B F C) for the satellite with input factors f1, f2, worked out by hand:
    s^2 + (f1 + f2) s + f1 f2 + a^2 (1 - f1)(1 - f2)."""
    return np.roots([1.0, f1 + f2, f1 * f2 + a * a * (1 - f1) * (1 - f2)])


def test_the_satellite_simultaneous_gain_margin_is_its_closed_form():
    """Gains k and 1/k: the determinant 1 - a^2 (k - 1)^2 / k reaches 0 at (k - 1)^2 / k = 1/a^2."""
    plant = checked_plant(*satellite(), "satellite")
    disk = multi_loop_disk_margin(plant)
    found = simultaneous(plant, "gain", disk)
    k = optimize.brentq(lambda x: (x - 1) ** 2 / x - 1 / A_SPIN**2, 1.0 + 1e-9, 2.0, xtol=1e-15)
    assert found.upper == pytest.approx(20 * np.log10(k), rel=1e-9)
    assert found.lower == pytest.approx(disk.gain_db, rel=1e-12) and found.lower <= found.upper
    f1, f2 = 10 ** (np.array(found.perturbation) / 20)
    assert satellite_characteristic(f1, f2).real.max() == pytest.approx(0.0, abs=1e-9)


def test_the_satellite_simultaneous_phase_margin_is_the_disk_s():
    plant = checked_plant(*satellite(), "satellite")
    disk = multi_loop_disk_margin(plant)
    found = simultaneous(plant, "phase", disk)
    assert found.status == "tight" and found.upper == pytest.approx(5.7106, abs=5e-5)
    f1, f2 = np.exp(1j * np.radians(found.perturbation))
    roots = satellite_characteristic(f1, f2)
    k = np.argmax(roots.real)
    assert abs(roots[k].real) < 1e-9 and abs(abs(roots[k].imag) - found.frequency) < 1e-9


@pytest.mark.parametrize("kind", ["gain", "phase"])
def test_simultaneous_changes_inside_the_lower_bound_are_stable_and_the_one_found_is_not(kind):
    a, b, c, d = random_plant(np.random.default_rng(21), 10, 3)
    plant = checked_plant(a, b, c, d, "random")
    found = simultaneous(plant, kind, multi_loop_disk_margin(plant))
    rng = np.random.default_rng(0)

    def abscissa_of(values):
        f = 10 ** (values / 20) if kind == "gain" else np.exp(1j * np.radians(values))
        return np.linalg.eigvals(a - b @ np.diag(f) @ np.linalg.solve(np.eye(3) + d @ np.diag(f), c)).real.max()

    inside = [abscissa_of(found.lower * rng.uniform(-1, 1, 3)) for _ in range(300)]
    corners = [abscissa_of(found.lower * (1 - 1e-9) * (2 * np.array(s) - 1)) for s in np.ndindex(2, 2, 2)]
    assert max(inside + corners) < 0
    assert abscissa_of(np.array(found.perturbation)) == pytest.approx(0.0, abs=1e-9)
    assert found.lower <= found.upper == pytest.approx(np.abs(found.perturbation).max(), rel=1e-12)


# --- breaks of a block diagram ----------------------------------------------------------------


def two_by_two_diagram(k: float = 3.0):
    """P = k [[1/(s+1), 0.5/(s+2)], [-0.8/(s+3), 2/(s+4)]] drawn as four blocks and two sums, u = r - y;
    and the same plant realized by hand (A diag(-1, -2, -3, -4))."""
    from engine.model.blocks import ExpressionTransfer
    from engine.model.network import Block, Junction, block_diagram

    entries = [("u1", "y1", f"{k}/(s+1)"), ("u2", "y1", f"{0.5 * k}/(s+2)"), ("u1", "y2", f"{-0.8 * k}/(s+3)")]
    entries.append(("u2", "y2", f"{2 * k}/(s+4)"))
    blocks = [Block(f"p{i}", u, f"a{i}", ExpressionTransfer(t)) for i, (u, _, t) in enumerate(entries)]
    sums = [
        Junction(f"s{y}", y, tuple((1.0, f"a{i}") for i, (_, to, _) in enumerate(entries) if to == y))
        for y in ("y1", "y2")
    ]
    errors = [Junction(f"e{j}", f"u{j}", ((1.0, f"r{j}"), (-1.0, f"y{j}"))) for j in (1, 2)]
    network = block_diagram(blocks, sums + errors, ["r1", "r2"], "s")
    a = np.diag([-1.0, -2.0, -3.0, -4.0])
    b = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
    c = np.array([[k, 0.5 * k, 0.0, 0.0], [0.0, 0.0, -0.8 * k, 2 * k]])
    return network, (a, b, c, np.zeros((2, 2)))


def test_a_diagram_broken_at_two_signals_is_the_plant_realized_by_hand():
    from engine.multiloop.network_breaks import diagram_disk_margin

    network, matrices = two_by_two_diagram()
    mine = diagram_disk_margin(network, ["u1", "u2"], {})
    by_hand = multi_loop_disk_margin(checked_plant(*matrices, "by hand"))
    peak, _ = reference_lower(*matrices)
    assert mine.status == "certified" and mine.alpha_upper == pytest.approx(by_hand.alpha_upper, rel=1e-9)
    assert mine.alpha_lower <= 1.0 / peak * (1 + 1e-12) and mine.alpha_upper == pytest.approx(1.0 / peak, rel=1e-6)
    plant = checked_plant(*matrices, "by hand")
    for name in ("u1", "u2"):
        in_diagram = analyze(network, name, OMEGA, {})
        alone = analyze(unity_feedback(["1"], state_space=break_loop(plant, name)), "e", OMEGA, {})
        assert [p.frequency for p in in_diagram.margins.phase] == pytest.approx(
            [p.frequency for p in alone.margins.phase], rel=1e-9
        )
        assert in_diagram.disk_margin.alpha == pytest.approx(alone.disk_margin.alpha, rel=1e-9)

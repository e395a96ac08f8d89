"""Blocks typed as a sum of modes (issue 35, section 5's remaining class): k0/s + sum k_i/(s^2 +
2 z_i w_i s + w_i^2) with lightly damped (zeta 1e-3..1e-2), closely spaced modes (within 5 %).
The zeros of such a sum lie between its modes, and the roots of its expanded numerator (over the
common denominator) placed them to 1e-6..1e-2 relative (twenty modes: 0.1, or elsewhere): before
engine.model.factored polished them on the sum, 12 of these 60 eight-mode loops C(s) * sum had a
gain crossover or phase crossing off by 5.8e-7..1.3e-4 relative (median 6e-6), now 5e-15 at most.
The references are written here: L(j w) term by term in mpmath at 40 digits, its crossings
bracketed on a dense grid (float, term by term) and refined by mpmath.findroot; the zeros refined
by mpmath.findroot on the sum."""

from __future__ import annotations

import warnings

import mpmath
import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.loop.responses import loop_model
from engine.margins.search import margins
from engine.model.expressions import Expression
from engine.model.factored import pole_zero
from engine.numerics.aberth import aberth

LOOPS = 60
MODES = 8
DIGITS = 40
FREQUENCY = 1e-11  # relative, a crossing's frequency against the reference
MARGIN = 1e-11  # relative: |GH| at a phase crossing; the phase margin in units of 180 deg
ROUNDINGS = 4  # of a crossing's frequency, by which a margin may move besides (`_errors`)
EPS = float(np.finfo(float).eps)


def _number(x: float) -> float:
    """A number as it is typed (six digits): the engine parses the text, the reference reads the float."""
    return float(f"{x:.6g}")


def _modes(seed: int, modes: int = MODES, integrators: int = 1) -> tuple[str, list[tuple[float, float, float]]]:
    """k0/s^integrators + sum k_i/(s^2 + b_i s + c_i): its text and its numbers [(k0, 0, 0), (k_i, b_i, c_i)...]."""
    rng = np.random.default_rng(seed)
    w0 = 10 ** rng.uniform(-1, 2)
    w = w0 * (1 + rng.uniform(0, 0.05, modes))
    zeta = 10 ** rng.uniform(-3, -2, modes)
    k = rng.uniform(0.2, 1.0, modes) * w**2 * rng.choice([-1, 1], modes)
    terms = [(_number(rng.uniform(0.5, 2)), 0.0, 0.0)]
    terms += [(_number(a), _number(2 * z * v), _number(v * v)) for a, z, v in zip(k, zeta, w)]
    power = "s" if integrators == 1 else f"s^{integrators}"
    text = f"{terms[0][0]!r}/{power}" + "".join(f"{a:+.6g}/(s^2+{b!r}*s+{c!r})" for a, b, c in terms[1:])
    return text, terms


def _case(seed: int) -> dict:
    """A loop C(s) * sum: C a lead K (s/a + 1)/(s/b + 1) about a crossover among or near the modes."""
    text, terms = _modes(seed)
    rng = np.random.default_rng(10_000 + seed)
    modes = np.sqrt([c for _, _, c in terms[1:]])
    wc = _number(float(np.mean(modes)) * 10 ** rng.uniform(-0.7, 0.3))
    gain, a, b = _number(wc / terms[0][0] / 3), _number(wc / 3), _number(wc * 3)
    return {"sum": text, "terms": terms, "lead": (gain, a, b), "compensator": f"{gain!r}*(s/{a!r}+1)/(s/{b!r}+1)"}


def _sum_mp(terms: list[tuple[float, float, float]], s, integrators: int = 1):
    value = mpmath.mpf(terms[0][0]) / s**integrators
    for k, b, c in terms[1:]:
        value += mpmath.mpf(k) / (s * s + mpmath.mpf(b) * s + mpmath.mpf(c))
    return value


def _loop_mp(case: dict, w):
    s = mpmath.mpc(0, w)
    gain, a, b = (mpmath.mpf(x) for x in case["lead"])
    return gain * (s / a + 1) / (s / b + 1) * _sum_mp(case["terms"], s)


def _loop_np(case: dict, w: np.ndarray) -> np.ndarray:
    s = 1j * w
    gain, a, b = case["lead"]
    value = case["terms"][0][0] / s
    for k, bb, c in case["terms"][1:]:
        value = value + k / (s * s + bb * s + c)
    return gain * (s / a + 1) / (s / b + 1) * value


def _reference(case: dict) -> dict[str, list]:
    """Gain crossovers (|L| = 1, "P") and phase crossings (Im L = 0 with Re L < 0, "G"): bracketed on
    200 000 log-spaced points and 400 001 across the modes' band (steps of 1e-6 of it), refined by
    mpmath.findroot at 40 digits on L term by term."""
    modes = np.sqrt([c for _, _, c in case["terms"][1:]])
    lo, hi = min(modes.min(), case["lead"][1]), max(modes.max(), case["lead"][2])
    w = np.unique(
        np.concatenate(
            [np.geomspace(lo * 1e-4, hi * 1e4, 200_000), np.linspace(0.9 * modes.min(), 1.1 * modes.max(), 400_001)]
        )
    )
    value = _loop_np(case, w)
    found: dict[str, list] = {}
    with mpmath.workdps(DIGITS):
        for kind, sampled, level in (
            ("P", np.log(np.abs(value)), lambda x: mpmath.log(abs(_loop_mp(case, x)))),
            ("G", value.imag, lambda x: mpmath.im(_loop_mp(case, x))),
        ):
            roots = []
            for i in np.flatnonzero(sampled[:-1] * sampled[1:] < 0):
                root = mpmath.findroot(level, (mpmath.mpf(w[i]), mpmath.mpf(w[i + 1])), solver="anderson")
                if kind == "P" or mpmath.re(_loop_mp(case, root)) < 0:
                    roots.append((root, _loop_mp(case, root)))
            found[kind] = roots
    return found


def _errors(case: dict) -> tuple[float, int]:
    """The largest error of the loop's crossings (relative) and margins against the reference, in
    units of what is asked (`FREQUENCY`, `MARGIN`), and how many crossings the engine has too many or
    too few.  A margin is asked to MARGIN plus what ROUNDINGS roundings of its frequency move it,
    |w d log L / dw| eps each: beside a zero pair of damping 1e-6 |L| moves by 1e-10 over one rounding
    of the frequency, and no float frequency (nor zero) does better."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = margins(
            loop_model(unity_feedback([case["compensator"], case["sum"]]), "e", np.logspace(-3, 4, 400), {})
        )
    reference = _reference(case)
    worst, miscount = 0.0, 0
    for kind, listed in (("P", found.phase), ("G", found.gain)):
        exact = reference[kind]
        miscount += abs(len(listed) - len(exact))
        for margin, (w, gh) in zip(listed, exact):
            worst = max(worst, abs(margin.frequency - float(w)) / float(w) / FREQUENCY)
            with mpmath.workdps(DIGITS):
                slope = abs(w * mpmath.diff(lambda x: _loop_mp(case, x), w) / gh)
                if kind == "G":  # the gain margin: |GH| at the crossing
                    error = abs(abs(margin.gh) - abs(gh)) / abs(gh)
                else:  # the phase margin, 180 + arg GH in degrees, in units of 180 deg
                    exact_pm = 180 + mpmath.degrees(mpmath.arg(gh))
                    error = abs(margin.phase_deg - (exact_pm - 360 if exact_pm > 180 else exact_pm)) / 180
            worst = max(worst, float(error / (MARGIN + ROUNDINGS * EPS * slope)))
    return worst, miscount


@pytest.mark.long
def test_crossovers_and_margins_of_eight_mode_loops_match_mpmath() -> None:
    """60 random eight-mode loops: every gain crossover and phase crossing found, at its frequency to
    1e-11 relative, with |GH| there (the gain margin) and the phase margin to 1e-11 (`_errors`)."""
    off = []
    for seed in range(LOOPS):
        worst, miscount = _errors(_case(seed))
        if worst > 1 or miscount:
            off.append((seed, f"{worst:.1e}", miscount))
    assert off == [], (
        f"{len(off)} of {LOOPS} loops off (seed, worst error in units of the tolerance, crossings missed or extra)"
    )


def _mp_root(f, z: complex) -> complex:
    """mpmath.findroot (secant from z and a point 1e-9 away) at 40 digits."""
    with mpmath.workdps(DIGITS):
        start = mpmath.mpc(z)
        return complex(mpmath.findroot(f, (start, start * (1 + mpmath.mpf(1e-9))), verify=False))


@pytest.mark.parametrize(
    "modes, integrators",
    [(8, 1), (8, 2), (20, 1), (20, 2)],
    ids=["eight-modes", "eight-modes-double-integrator", "twenty-modes", "twenty-modes-double-integrator"],
)
def test_zeros_of_a_sum_of_modes_are_its_roots_in_exact_pairs(modes: int, integrators: int) -> None:
    """The zeros of random sums (a double integrator k0/s^2 is a repeated pole: a Jordan chain in the
    realization), each where mpmath's root of the sum is, to 1e-12 relative, conjugate pairs bit for
    bit; twenty modes within 5 % put the numerator's roots 0.1 off."""
    for seed in range(6):
        text, terms = _modes(100 + seed, modes, integrators)
        form = pole_zero(Expression(text, "s"), {})
        assert form.zeros.size == 2 * modes
        for z in form.zeros:
            exact = _mp_root(lambda s: _sum_mp(terms, s, integrators), complex(z))
            assert abs(z - exact) <= 1e-12 * abs(exact), (seed, z, exact)
        upper, lower = form.zeros[form.zeros.imag > 0], form.zeros[form.zeros.imag < 0]
        assert np.array_equal(np.sort_complex(upper), np.sort_complex(lower.conj()))


def test_a_mode_two_terms_share_is_one_pole_and_no_zero() -> None:
    """Terms sharing a mode (the realization has its state twice: one spurious zero there, removed)."""
    text = "1/s + 2/(s^2+0.02*s+1) - 0.5/(s^2+0.02*s+1) + 1.2/(s^2+0.021*s+1.0201) - 0.9/(s^2+0.0204*s+1.0404)"
    form = pole_zero(Expression(text, "s"), {})
    assert form.poles.size == 7 and form.zeros.size == 6

    def f(s):
        return (
            1 / s
            + mpmath.mpf("1.5") / (s * s + mpmath.mpf(0.02) * s + 1)
            + mpmath.mpf(1.2) / (s * s + mpmath.mpf(0.021) * s + mpmath.mpf(1.0201))
            - mpmath.mpf(0.9) / (s * s + mpmath.mpf(0.0204) * s + mpmath.mpf(1.0404))
        )

    for z in form.zeros:
        assert abs(z - _mp_root(f, complex(z))) <= 1e-12 * abs(z)


def test_aberth_keeps_pairs_exact_and_stops_on_a_root() -> None:
    """(x - 2)(x^2 + 0.002 x + 1)(x - 3): estimates 1e-3 off come back to 1e-15, the pair exact; an
    estimate already on a root (p'/p infinite there) stays."""
    roots = np.array([2.0, -0.001 + 1j * np.sqrt(1 - 1e-6), -0.001 - 1j * np.sqrt(1 - 1e-6), 3.0])

    def log_slope(x):
        with np.errstate(divide="ignore"):
            return np.sum(1.0 / (x[:, None] - roots[None, :]), axis=1)

    start = np.array([2.002, roots[1] * (1 + 1e-3j), (roots[1] * (1 + 1e-3j)).conjugate(), 3.0])
    result = aberth(log_slope, start, conjugate=True)
    polished, settled = result.roots, result.settled
    assert settled.all()
    assert np.max(np.abs(np.sort_complex(polished) - np.sort_complex(roots))) <= 1e-15 * 3
    assert polished[-1] == polished[-2].conjugate() and polished[1] == 3.0

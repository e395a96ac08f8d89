"""High-order loops typed as one factored expression (issue 35, section 1): no expansion
overflows, and the closed-loop poles are the exact roots (mpmath, 120 digits, precomputed
by data/make_high_order_loops.py), in exact conjugate pairs, each checked as a root."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import mpmath
import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback
from engine.closed_loop.poles import CONFIRMED, checked
from engine.loop.realization import Pole

LOOPS = json.loads((Path(__file__).parent / "data" / "high_order_loops.json").read_text())
OMEGA = np.logspace(-2, 6, 400)


@pytest.mark.parametrize("case", LOOPS, ids=lambda c: f"seed{c['seed']}-{c['draw']}")
def test_closed_loop_poles_are_the_exact_roots_in_conjugate_pairs(case: dict) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = analyze(unity_feedback([case["text"]]), "e", OMEGA, {})
    exact = np.array([complex(re, im) for re, im in case["poles"]])
    got = np.array([p.value for p in a.closed_loop_poles])
    assert got.size == exact.size
    for g in got:  # relative to the root, down to the floating-point range
        assert np.min(np.abs(exact - g)) <= 1e-9 * max(abs(g), 1e-270), g
    upper, lower = np.sort_complex(got[got.imag > 0]), np.sort_complex(got[got.imag < 0].conj())
    assert np.array_equal(upper, lower)  # exact pairs, bit for bit
    assert all(p.backward_error <= CONFIRMED for p in a.closed_loop_poles)
    # the documented rule on the exact roots: on the axis when |Re p| <= 1e-12 |p| or |p| <= 1e-12 max |p|
    on_axis = (np.abs(exact.real) <= 1e-12 * np.abs(exact)) | (np.abs(exact) <= 1e-12 * np.max(np.abs(exact)))
    verdict = "unstable" if np.any((exact.real > 0) & ~on_axis) else "marginally stable" if on_axis.any() else "stable"
    assert a.verdict == verdict


def test_a_pole_that_is_no_root_is_named() -> None:
    """A pole off by 7 % (as the expanded polynomial's were) is flagged, not shown as a root."""
    network = unity_feedback(["4/((s+1)*(s+2)*(s+3))"])
    a = analyze(network, "e", OMEGA, {})
    assert not any("not roots" in n for n in a.notes)
    wrong = [Pole(p.value * 1.073, p.damping, p.natural_frequency) for p in a.closed_loop_poles]
    poles, notes = checked(network, {}, wrong)
    assert all(p.backward_error > 1e-3 for p in poles)
    assert notes and "3 closed-loop pole(s) are not roots" in notes[0]


def test_a_huge_gain_does_not_overflow_the_search() -> None:
    """1e200 (s + 3000..)^40 / (s (s + 5000..)^56): the numerator's coefficients overflow a
    double (the corners were read from them: 'its polynomial coefficients overflow'); the
    crossover is where mpmath's |L(j w)| = 1 in factored form."""
    rng = np.random.default_rng(1)
    zeros, poles = 10 ** rng.uniform(3, 4, 40), 10 ** rng.uniform(3, 4, 56)
    text = "1e200*" + "*".join(f"(s+{w:.5g})" for w in zeros) + "/(s*" + "*".join(f"(s+{w:.5g})" for w in poles) + ")"
    zeros, poles = [float(f"{w:.5g}") for w in zeros], [float(f"{w:.5g}") for w in poles]
    a = analyze(unity_feedback([text]), "e", OMEGA, {})

    def log_gain(w):
        s = mpmath.mpc(0, w)
        return mpmath.log(
            abs(mpmath.mpf(1e200) * mpmath.fprod(s + z for z in zeros) / (s * mpmath.fprod(s + p for p in poles)))
        )

    mpmath.mp.dps = 40
    wc = a.margins.crossover_frequency
    assert wc is not None and abs(float(mpmath.findroot(log_gain, wc)) - wc) <= 1e-9 * wc

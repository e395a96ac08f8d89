"""The pure delay and the verdict's rule (issue 35, section 6)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.analysis import analyze, unity_feedback

GRID = np.logspace(-3, 3, 400)


def test_the_pure_delay_summarizes_its_periodic_family() -> None:
    """exp(-s): |GH| = 1 everywhere; a gain and a stability margin at every (2k + 1) pi rad/s
    up to the grid's 1000 (159 of each) were all printed, and the disk phase read 'inf'."""
    a = analyze(unity_feedback(["1"], delay=1.0), "e", GRID, {})
    expected = int((1000 / math.pi - 1) // 2) + 1
    families = {f.kind: f for f in a.margins.families}
    assert families["G"].count == expected and families["S"].count == expected
    assert families["G"].period == pytest.approx(2 * math.pi)
    assert len(a.margins.listed("G")) <= 15 and len(a.margins.listed("S")) <= 15
    alpha = a.disk_margin.alpha
    assert a.disk_margin.phase_deg == pytest.approx(math.degrees(2 * math.atan(alpha / 2)), abs=1e-9)


def test_a_slow_pole_is_stable_not_marginal() -> None:
    """(s + z)/(s (s + 3)) at z = 1.12e-10: s^2 + 4 s + z has a root at -z/4 (2.8e-11 s^-1),
    the other near -4: asymptotically stable; it was 'marginally stable'."""
    z = 1.12e-10
    a = analyze(unity_feedback([f"(s+{z!r})/(s*(s+3))"]), "e", GRID, {})
    slow = -2 * z / (4 + math.sqrt(16 - 4 * z))
    assert min(abs(p.value) for p in a.closed_loop_poles) == pytest.approx(abs(slow), rel=1e-9)
    assert a.verdict == "stable"


def test_a_marginal_verdict_names_its_poles_and_rule() -> None:
    a = analyze(unity_feedback(["1/(s^2+1)"]), "e", GRID, {})
    assert a.verdict == "marginally stable"
    note = next(n for n in a.notes if n.startswith("marginally stable"))
    assert "1.41421" in note and "1e-12" in note

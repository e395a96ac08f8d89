"""Targets on the disk margin, Ms, Mt and the delay margin (issue 20): the
tableau's values against python-control (`disk_margins` on a dense grid
around the worst frequency, `stability_margins` for the delay margin) and
dense sampling (Ms, Mt); slp's analytic partials against central
differences; cip's rows against the gradient of the measure's own stability
margin |1 + F| (central differences at the fixed frequency)."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.cip.direction import gradient_rows
from engine.cip.requirements import check_targets, detect
from engine.design.measure_kinds import kind
from engine.design.problem import BandValue, Condition, Grid, Parameter, Point, Problem, Target
from engine.design.tableau import tableau
from engine.errors import EngineError
from engine.margins.peak_measures import loop_derivative
from engine.slp.measures import evaluate, measure_specs
from engine.slp.partials import jacobian
from engine.stepping.registry import lookup

PLANT = "10/(s*(s+1)*(s+5))"
LEAD = "K*(1+T*s)/(1+a*T*s)"
NEW = ("disk_margin", "sensitivity_peak", "complementary_sensitivity_peak", "delay_margin")
# (K, T, a): the lead loop as designed, and a lightly damped resonance beside it
POINTS = [(1.0, 1.0, 0.1), (0.6, 0.4, 0.3)]


def problem(values, targets, resonance: bool = False) -> Problem:
    chain = [LEAD, PLANT] + (["400/(s**2 + 0.8*s + 400)"] if resonance else [])
    names = ("K", "T", "a")
    return Problem(
        (Condition("c", unity_feedback(chain), "e"),),
        tuple(Parameter(n, v, 1e-3, 1e3) for n, v in zip(names, values)),
        tuple(targets),
        Grid(np.geomspace(0.01, 100, 300)),
    )


def target(measure: str, desired: float | None = None, band=(0.0, np.inf)) -> Target:
    value = kind(measure).default_desired if desired is None else desired
    return Target(measure, (BandValue(band[0], band[1], value),))


def python_control_loop(values, resonance: bool = False) -> control.TransferFunction:
    K, T, a = values
    L = control.tf([K * T, K], [a * T, 1]) * control.tf([10], [1, 6, 5, 0])
    return L * control.tf([400], [1, 0.8, 400]) if resonance else L


def rows(values, resonance=False) -> dict[str, object]:
    return {r.kind: r for r in tableau(problem(values, [target(m) for m in NEW], resonance))}


def dense_peak(magnitude, w0: float) -> float:
    """max of magnitude(w) on 200001 points within 0.1 % of w0 (its grid maximum: from below)."""
    w = np.geomspace(w0 * 0.999, w0 * 1.001, 200_001)
    return float(np.max(magnitude(w)))


@pytest.mark.parametrize("resonance", [False, True])
@pytest.mark.parametrize("values", POINTS)
def test_values_match_python_control_and_dense_sampling(values, resonance):
    found = rows(values, resonance)
    L = python_control_loop(values, resonance)
    disk = found["disk_margin"]
    dm, _, _ = control.disk_margins(L, np.geomspace(disk.frequency * 0.999, disk.frequency * 1.001, 20_001))
    assert disk.value == pytest.approx(dm, rel=1e-7) and disk.value <= dm * (1 + 1e-12)  # grid min is above
    for measure, f in (
        ("sensitivity_peak", lambda g: 1 / (1 + g)),
        ("complementary_sensitivity_peak", lambda g: g / (1 + g)),
    ):
        row = found[measure]
        sampled = dense_peak(lambda w: np.abs(f(L(1j * w))), row.frequency)
        assert row.value == pytest.approx(sampled, rel=1e-9) and row.value >= sampled * (1 - 1e-13)
    # python-control 0.10.2 reports no delay margin: its phase margin over its crossover frequency
    # (one crossover here; stability_margins finds it from the polynomials' roots)
    _, pm, _, _, wgc, _ = control.stability_margins(L)
    assert found["delay_margin"].value == pytest.approx(math.radians(pm) / wgc, rel=1e-9)
    assert found["delay_margin"].frequency == pytest.approx(wgc, rel=1e-9)


def test_the_whole_axis_is_searched_not_the_grid():
    """Over the first point's loop a dense sweep of the whole axis finds no larger |S| or |T|."""
    found = rows(POINTS[0])
    L = python_control_loop(POINTS[0])
    w = np.geomspace(1e-4, 1e4, 400_001)
    g = L(1j * w)
    assert np.max(np.abs(1 / (1 + g))) <= found["sensitivity_peak"].value * (1 + 1e-12)
    assert np.max(np.abs(g / (1 + g))) <= found["complementary_sensitivity_peak"].value * (1 + 1e-12)
    assert 1 / np.max(np.abs(1 / (1 + g) - 0.5)) >= found["disk_margin"].value * (1 - 1e-12)


def test_an_unstable_closed_loop_has_no_disk_margin_and_infinite_peaks():
    found = rows((8.0, 0.01, 0.5))  # K = 8: well past the gain limit of 10/(s(s+1)(s+5)) (K < 3)
    assert found["disk_margin"].value == 0.0 and not found["disk_margin"].satisfied
    assert math.isinf(found["sensitivity_peak"].value) and math.isinf(found["complementary_sensitivity_peak"].value)


def test_a_band_limits_the_peak():
    L = python_control_loop(POINTS[0])
    row = tableau(problem(POINTS[0], [target("sensitivity_peak", band=(0.01, 1.0))]))[0]
    assert row.frequency == pytest.approx(1.0)  # |S| rises through the band: its top edge
    assert row.value == pytest.approx(abs(1 / (1 + L(1j))), rel=1e-12)


# -- slp ------------------------------------------------------------------------


@pytest.mark.parametrize("resonance", [False, True])
@pytest.mark.parametrize("values", POINTS)
def test_slp_partials_are_analytic_and_match_central_differences(values, resonance):
    p = problem(values, [target(m) for m in NEW], resonance)
    specs = [s for s in measure_specs(p, require_stable=False)]
    x = p.vector()
    v, f = evaluate(p, x, specs)
    J, how = jacobian(p, x, specs, v, f)
    assert how == ("analytic",) * len(NEW)
    for j in range(x.size):
        h = 1e-5 * abs(x[j])
        up, down = x.copy(), x.copy()
        up[j] += h
        down[j] -= h
        central = (evaluate(p, up, specs)[0] - evaluate(p, down, specs)[0]) / (2 * h)
        np.testing.assert_allclose(J[:, j], central, rtol=2e-6, atol=1e-9)


def test_slp_names_its_rows_and_falls_back_where_not_differentiable():
    p = problem((8.0, 0.01, 0.5), [target(m) for m in NEW])
    specs = measure_specs(p, require_stable=False)
    assert [s.name for s in specs] == ["DM1", "SPK1", "TPK1", "DLY1"]
    v, f = evaluate(p, p.vector(), specs)
    J, how = jacobian(p, p.vector(), specs, v, f)
    assert v[0] == 0.0 and how[0] == "finite difference" and how[1] == how[2] == ""  # inf: absent from the LP


# -- cip ------------------------------------------------------------------------


def test_cip_accepts_the_peaks_and_refuses_the_delay_margin_saying_why():
    cip = lookup("cip").targets
    assert all(cip.accepts(m) for m in NEW[:3]) and not cip.accepts("delay_margin")
    check_targets(problem(POINTS[0], [target(m) for m in NEW[:3]]))
    with pytest.raises(EngineError, match="'delay_margin' is not a distance cip can push at one frequency.*use slp"):
        check_targets(problem(POINTS[0], [target("delay_margin")]))
    pushed = Target("disk_margin", (BandValue(0, np.inf, 0.5),), points=(Point(-1.0, "push"),))
    with pytest.raises(EngineError, match="takes no points"):
        check_targets(problem(POINTS[0], [pushed]))


def test_cip_ms_rows_are_its_stability_margins():
    p = problem(POINTS[1], [target("sensitivity_peak", 1.2), target("stability_margin", 1 / 1.2)], resonance=True)
    found, _ = detect(p, p.vector(), "auto")
    ms = [c for c in found if c.measure == "sensitivity_peak"]
    sm = [c for c in found if c.measure == "stability_margin"]
    assert [(c.kind, c.frequency, c.value, c.desired, c.active) for c in ms] == [
        (c.kind, c.frequency, c.value, c.desired, c.active) for c in sm
    ]
    assert max(c.shown for c in ms) == pytest.approx(rows(POINTS[1], True)["sensitivity_peak"].value, rel=1e-12)


@pytest.mark.parametrize("measure", ["disk_margin", "complementary_sensitivity_peak"])
@pytest.mark.parametrize("resonance", [False, True])
def test_cip_rows_push_along_the_gradient_of_the_measures_stability_margin(measure, resonance):
    p = problem(POINTS[1], [target(measure, 10.0 if measure == "disk_margin" else 0.01)], resonance)
    x = p.vector()
    found, _ = detect(p, x, "auto")
    assert found and all(c.kind == "D" and c.active for c in found)
    worst = min(c.value for c in found)
    reference = rows(POINTS[1], resonance)[measure].value
    assert (worst if measure == "disk_margin" else 1 / worst) == pytest.approx(reference, rel=1e-10)
    grads = gradient_rows(p, x, found).gradients
    for c, row in zip(found, grads):

        def margin(xv):  # |1 + F| = 1/|f| at the requirement's fixed frequency
            gh = python_control_loop(xv, resonance)(1j * c.frequency)
            return 1 / abs(loop_derivative(measure, gh)[0])

        central = np.array(
            [(margin(x + e) - margin(x - e)) / (2 * np.linalg.norm(e)) for e in np.diag(1e-6 * np.abs(x))]
        )
        assert margin(x) == pytest.approx(c.value, rel=1e-10)
        np.testing.assert_allclose(row / np.linalg.norm(row), central / np.linalg.norm(central), atol=1e-7)

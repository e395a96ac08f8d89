"""The requirements drawn where the engineer looks (issue 36, section 5): each overlay is
where the target puts it (closed forms written here), names its target and verdict in
the legend, is gray when met and red and shaded when violated."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sessions.store import load_session
from tui.figures import overlays
from tui.figures.catalog import figures
from tui.figures.data import Figure, Series
from tui.figures.navigation import data_box
from tui.figures.requirements import SHADE, Requirement, requirements
from tui.state.workbench import Workbench

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _view(example: str, steps: int = 1):
    bench = Workbench(load_session(EXAMPLES / f"{example}.json"))
    bench.session.path = None  # stepped in memory: no autosave beside the bundled example
    for _ in range(steps):
        bench.step()
    return bench.view()


def _drawn(fig: Figure, text: str) -> list[Series]:
    return [s for s in fig.series if text in s.label]


def _shaded(fig: Figure) -> bool:
    return any(s.marker == SHADE for s in fig.series)


def test_the_verdicts_are_the_tableaus():
    met = {r.measure: r.met for r in requirements(_view("report003_lag_lead"))}
    assert met == {"phase_margin_deg": True, "gain_margin_db": True, "stability_margin": True}
    kuo = {r.measure: r.met for r in requirements(_view("coebra_kuo_digital"))}
    assert kuo == {"gain_margin_db": False, "phase_margin_deg": False}


def test_bode_and_nichols_draw_the_margins_met_quietly_and_violated_in_red():
    met = figures(_view("report003_lag_lead"))
    gm = _drawn(met["bode-mag"], "GM >= 10 dB target: met")
    assert gm and gm[0].y == [-10.0, -10.0] and gm[0].color == "gray" and not _shaded(met["bode-mag"])
    unmet = figures(_view("coebra_kuo_digital"))
    gm = _drawn(unmet["bode-mag"], "GM >= 12 dB target: NOT met")
    assert gm and gm[0].y == [-12.0, -12.0] and gm[0].color == "red" and _shaded(unmet["bode-mag"])
    pm = _drawn(unmet["bode-phase"], "PM >= 50 deg target: NOT met")[0]
    assert pm.y[0] in (-130.0, -130.0 - 360.0, -130.0 + 360.0)
    box = _drawn(unmet["nichols"], "PM >= 50 deg target: NOT met")[0]
    base = pm.y[0] - 50.0  # the -180 deg branch the loop crosses at
    assert sorted(set(box.x)) == [base - 50.0, base + 50.0] and sorted(set(box.y)) == [-12.0, 12.0]


def test_nyquist_draws_the_ms_and_mt_circles_and_the_margins():
    fig = Figure(xlim=(-4.0, 2.0), ylim=(-3.0, 3.0))
    found = [
        Requirement("sensitivity_peak", 1.5, False, 0.0, math.inf, False),
        Requirement("complementary_sensitivity_peak", 1.3, False, 0.0, math.inf, True),
        Requirement("gain_margin_db", 6.0, True, 0.0, math.inf, True),
        Requirement("phase_margin_deg", 30.0, True, 0.0, math.inf, None),
    ]
    overlays.nyquist(fig, found)
    ms = _drawn(fig, "Ms <= 1.5 target: NOT met")[0]
    assert np.allclose(np.hypot(np.array(ms.x) + 1, ms.y), 1 / 1.5) and ms.color == "red"
    mt = _drawn(fig, "Mt <= 1.3 target: met")[0]
    gh = np.array(mt.x) + 1j * np.array(mt.y)
    assert np.allclose(np.abs(gh / (1 + gh)), 1.3)  # |T| = Mt on its circle
    gm = _drawn(fig, "GM >= 6 dB")[0]
    assert gm.x == [-1.0, -(10 ** (-6 / 20))] and gm.y == [0.0, 0.0]
    pm = _drawn(fig, "PM >= 30 deg target: not judged")[0]
    angles = np.degrees(np.angle(np.array(pm.x) + 1j * np.array(pm.y))) % 360
    assert np.allclose(np.hypot(pm.x, pm.y), 1) and math.isclose(angles.min(), 150) and math.isclose(angles.max(), 210)


def test_the_pole_map_draws_damping_rays_settling_and_frequency_bounds():
    fig = Figure(series=[Series([-3.0, -1.0, 0.5], [2.0, -2.0, 0.0], "poles", scatter=True)])
    found = [
        Requirement("overshoot_percent", 10.0, False, 0.0, math.inf, True),
        Requirement("settling_time", 2.0, False, 0.0, math.inf, False),
        Requirement("rise_time", 0.9, False, 0.0, math.inf, True),
        Requirement("stability_abscissa", 0.2, True, 0.0, math.inf, False),
    ]
    overlays.poles(fig, found)
    zeta = -math.log(0.1) / math.hypot(math.pi, math.log(0.1))  # 10 % overshoot: zeta 0.591
    for ray in _drawn(fig, "OS % <= 10 % target: met"):
        p = np.array(ray.x[1:]) + 1j * np.array(ray.y[1:])
        assert np.allclose(-p.real / np.abs(p), zeta)
    settle = _drawn(fig, "settle <= 2 s target: NOT met")[0]
    assert np.allclose(settle.x, -math.log(20) / 2.0) and settle.color == "red"
    arc = _drawn(fig, "rise <= 0.9 s")[0]
    assert np.allclose(np.hypot(arc.x, arc.y), 1.8 / 0.9) and max(arc.x) <= 1e-12
    assert _drawn(fig, "stab >= 0.2 1/s target: NOT met")[0].x == [-0.2, -0.2] and _shaded(fig)


def test_the_step_plot_draws_overshoot_times_and_the_final_value_band():
    t = np.linspace(0, 10, 200)
    y = 1 - np.exp(-t) * np.cos(2 * t)
    fig = Figure(series=[Series(t.tolist(), y.tolist(), "current")], ylim=(0.0, 1.3))
    found = [
        Requirement("overshoot_percent", 5.0, False, 0.0, math.inf, False),
        Requirement("settling_time", 4.0, False, 0.0, math.inf, True),
        Requirement("steady_state_error", 0.02, False, 0.0, math.inf, True),
    ]
    overlays.step(fig, found, final=0.98)
    assert _drawn(fig, "OS % <= 5 % target: NOT met")[0].y == [0.98 * 1.05] * 2 and _shaded(fig)
    assert _drawn(fig, "settle <= 4 s target: met")[0].x == [4.0, 4.0]
    assert sorted({v for s in _drawn(fig, "ss err <= 0.02") for v in s.y}) == [0.98, 1.02]


def test_the_stability_circle_and_the_history_views_carry_their_iterations_verdict():
    view = _view("cip_launch_vehicle", steps=2)
    fig = figures(view)["nyquist"]
    circle = _drawn(fig, "S >= 0.505 target: NOT met")[0]  # one of its S rows is below 0.505
    assert np.allclose(np.hypot(np.array(circle.x) + 1, circle.y), 0.505) and circle.color == "red"
    from tui.figures.history import history_figure

    for iteration in (0, 1, 2):
        verdicts = {r.measure: r.label for r in requirements(view, iteration)}
        for kind in ("nyquist", "bode", "phase", "nichols"):
            labels = {s.label for s in history_figure(view, iteration, kind=kind).series}
            drawn = [label for label in verdicts.values() if label in labels]
            assert kind in ("bode", "phase", "nichols") or verdicts["stability_margin"] in labels, (kind, labels)
            assert all(label in verdicts.values() for label in labels if " target: " in label), (kind, drawn)


def test_a_settling_time_bound_uses_the_targets_own_band():
    fig = Figure(series=[Series([-3.0, 0.5], [2.0, -2.0], "poles", scatter=True)])
    overlays.poles(fig, [Requirement("settling_time", 4.0, False, 0.0, math.inf, True, settling_band=0.02)])
    assert np.allclose(_drawn(fig, "settle <= 4 s")[0].x, -math.log(50) / 4.0)  # 2 %: e^(-sigma Ts) = 0.02


def test_a_requirement_never_hides_a_curve():
    """Requirement lines and shading are drawn beneath the curves: every braille dot of the
    curves (and their marks) alone is still drawn with the requirements and the other
    guides (the GM level drawn over the Bode magnitude cut the current curve where it
    crossed the line's row)."""
    from dataclasses import replace

    from tests.tui.test_plot_bounds import _dots
    from tui.drawing.text_canvas import draw

    for name, fig in figures(_view("coebra_kuo_digital")).items():
        if not any(" target: " in s.label for s in fig.series):
            continue
        box = data_box(fig)
        fixed = replace(fig, xlim=box[:2], ylim=box[2:], legend=False)  # one layout for both
        curves = [s for s in fig.series if not s.beneath and " target: " not in s.label and s.marker != SHADE]
        bare = replace(fixed, series=curves)  # the curves and their marks alone
        for width, height in ((100, 30), (70, 14)):
            assert _dots(draw(bare, width, height, "textual-dark").text.plain) <= _dots(
                draw(fixed, width, height, "textual-dark").text.plain
            ), (name, width, height)


def test_the_compensators_corners_are_marked_on_the_bode_magnitude(tmp_path):
    """A lead's zero (1/T1) and pole (1/T2) on the current magnitude curve, where the
    shaping table moves them (issue 38, section 2)."""
    from tui.cli import main

    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    bench = Workbench(load_session(path))
    values = {p.name: p.value for p in bench.session.model.problem.parameters}
    fig = figures(bench.view())["bode-mag"]
    zero, pole = _drawn(fig, "compensator zeros")[0], _drawn(fig, "compensator poles")[0]
    assert zero.x == pytest.approx([math.log10(1 / values["T1"])]) and pole.x == pytest.approx(
        [math.log10(1 / values["T2"])]
    )
    k = values["K"]
    for mark, w in ((zero, 1 / values["T1"]), (pole, 1 / values["T2"])):
        gh = k * (1 + values["T1"] * 1j * w) / (1 + values["T2"] * 1j * w) / ((1j * w) ** 2 * (1j * w + 10))
        assert mark.y[0] == pytest.approx(20 * math.log10(abs(gh)), abs=0.05)  # on the curve (its samples)

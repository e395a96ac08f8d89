"""The S/T, pole-zero and root-locus views against independent computations."""

from __future__ import annotations

import numpy as np
import pytest

from sessions.store import load_session
from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.figures.closed_loop import locus_figure, poles_figure, sensitivity_figure
from tui.state.workbench import Workbench


def _loop(s):
    return (s + 1) * (s + 5) / ((s + 0.1) * (s + 50)) * 16000 / (s * (s + 8) * (s + 20))


def test_the_marked_peaks_are_the_dense_maxima_and_the_poles_the_closed_loop_roots(workdir):
    view = Workbench(load_session(workdir / "report003_lag_lead.json")).view()
    fig = sensitivity_figure(view)
    w = np.logspace(-3, 4, 400001)
    L = _loop(1j * w)
    ms, mt = np.abs(1 / (1 + L)).max(), np.abs(L / (1 + L)).max()
    marked = {s.label.split()[0]: s.y[0] for s in fig.series if s.scatter}
    assert abs(marked["Ms"] - 20 * np.log10(ms)) < 1e-6 and abs(marked["Mt"] - 20 * np.log10(mt)) < 1e-6
    den = np.polymul(np.polymul([1, 0.1], [1, 50]), np.polymul([1, 0], np.polymul([1, 8], [1, 20])))
    num = 16000 * np.polymul([1, 1], [1, 5])
    expected = np.sort_complex(np.roots(np.polyadd(den, num)))
    closed = next(s for s in poles_figure(view).series if s.label == "closed-loop poles")
    assert np.allclose(np.sort_complex(np.array(closed.x) + 1j * np.array(closed.y)), expected, rtol=1e-9)
    locus = locus_figure(view)
    current = next(s for s in locus.series if s.label.startswith("k = 1"))
    assert np.allclose(np.sort_complex(np.array(current.x) + 1j * np.array(current.y)), expected, rtol=1e-9)


@synchronous
async def test_the_views_are_plot_tabs_and_the_locus_is_computed_when_shown(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        plots = app.screen.query_one("#plots")
        assert {"p-closed", "p-poles", "p-locus"} <= set(app.screen.plot_tabs)
        plots.active = "p-locus"
        await settle(app, pilot)
        await app.workers.wait_for_complete()
        await settle(app, pilot)
        figure = app.screen.query_one("#locus").figure
        assert figure.title.startswith("Root locus") and figure.series
    app = LoopcraftApp(workdir / "seidel_inlet_pi.json")  # tabulated: no poles to show
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        assert "p-closed" in app.screen.plot_tabs and "p-locus" not in app.screen.plot_tabs


def test_m_circles_and_the_exclusion_disk_are_what_they_say():
    from tui.figures.open_loop import m_circle, nyquist_figure
    from tui.figures.overlays import nyquist
    from tui.figures.requirements import Requirement

    for m_db in (0.5, 3.0, 6.0):
        phase, db = m_circle(m_db)
        L = 10 ** (db / 20) * np.exp(1j * np.radians(phase))
        assert np.allclose(20 * np.log10(np.abs(L / (1 + L))), m_db, atol=1e-9)
    fig = nyquist_figure([], [])
    nyquist(fig, [Requirement("disk_margin", 0.8, True, 0.0, np.inf, None)])
    edge = next(s for s in fig.series if s.label.startswith("disk >= 0.8"))
    L = np.array(edge.x) + 1j * np.array(edge.y)
    L = L[np.isfinite(L)]
    assert np.allclose(np.abs(1 / (1 + L) - 0.5), 1 / 0.8, rtol=1e-9)  # |S - 1/2| = 1/alpha on its edge


def test_the_run_tab_lists_the_closed_loop_poles_with_zeta_and_wn(workdir):
    from tui.figures.closed_loop import pole_lines

    view = Workbench(load_session(workdir / "report003_lag_lead.json")).view()
    den = np.polymul(np.polymul([1, 0.1], [1, 50]), np.polymul([1, 0], np.polymul([1, 8], [1, 20])))
    roots = np.roots(np.polyadd(den, 16000 * np.polymul([1, 1], [1, 5])))
    pair = next(r for r in roots if r.imag > 0)
    line = next(t for t in pole_lines(view).splitlines() if "+-" in t).split()
    assert float(line[0]) == pytest.approx(pair.real, rel=1e-4) and float(line[2][:-1]) == pytest.approx(
        pair.imag, rel=1e-4
    )
    assert float(line[3]) == pytest.approx(-pair.real / abs(pair), rel=1e-2)
    assert float(line[4]) == pytest.approx(abs(pair), rel=1e-4)


@synchronous
async def test_the_pole_lines_are_made_off_the_ui_thread_and_shown_for_each_step(workdir, monkeypatch):
    """A launch vehicle's pole lines take 25 ms: the run's worker or a thread worker makes them."""
    import threading

    import tui.figures.closed_loop as views

    threads, lines = [], views.pole_lines

    def watched(view):
        threads.append(threading.current_thread() is threading.main_thread())
        return lines(view)

    monkeypatch.setattr(views, "pole_lines", watched)
    monkeypatch.setattr("tui.screens.main.pole_lines", watched, raising=False)  # where the screen made them
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("s")
        await settle(app, pilot)
        assert app.bench.iteration == 1
        tableau = str(app.screen.query_one("#tableau").render())
        expected = lines(app.bench.view())
        assert "closed-loop poles" in tableau and expected.splitlines()[2] in tableau and "computing" not in tableau
    assert len(threads) >= 2 and not any(threads)  # the first view's, and the step's


@synchronous
async def test_the_pole_lines_come_with_a_sweep_kept_in_the_session(workdir):
    """The views' key holds the latest sweep's identity: the same while it is the same sweep
    (its JSON data was made anew for every view, and the pole lines never matched)."""
    from sessions.format.schema import SweepModel

    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        app.bench.session.model.sweeps.append(
            SweepModel(version=2, kind="starts", created="x", algorithm=app.bench.algorithm_name)
        )
        assert app.bench.sweeps.latest() is app.bench.sweeps.latest()
        await pilot.press("s")
        await settle(app, pilot)
        await settle(app, pilot)
        tableau = str(app.screen.query_one("#tableau").render())
        assert app.bench.iteration == 1 and "closed-loop poles" in tableau and "computing" not in tableau


@pytest.mark.long
@synchronous
async def test_L_draws_the_locus_in_a_parameter(workdir):
    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("L")
        await pilot.pause()
        choices = [name for name, _ in app.screen.choices]
        assert choices[0] == "gain" and "p2" in choices
        app.screen.dismiss("p2")
        await settle(app, pilot)
        await app.workers.wait_for_complete()
        await settle(app, pilot)
        figure = app.screen.query_one("#locus").figure
        assert figure.title.startswith("Root locus in p2") and "p2=" in figure.xlabel
        # the crossing: 1 + L(jw) = 0 there, L = 16000 (s+1)(s+5) / ((s+0.1)(s+p2) s (s+8)(s+20))
        p2, w = (float(v) for v in figure.xlabel.split("p2=")[1].split(" rad/s")[0].split(" at "))
        s = 1j * w
        residual = abs(1 + 16000 * (s + 1) * (s + 5) / ((s + 0.1) * (s + p2) * s * (s + 8) * (s + 20)))
        assert residual < 1e-3  # the label's 4 digits


def test_an_unstable_loop_marks_its_peaks_unbounded(tmp_path):
    """The lead K (1 + T1 s)/(1 + T2 s) at K = 600, T1 = 1, T2 = 0.1 on 1/(s (s + 1)(s + 2)):
    s (s + 1)(s + 2)(1 + 0.1 s) + 600 (1 + s) has roots right of the axis; the |S|, |T| and
    |KS| peaks on the axis bound nothing (issue 37, section 3)."""
    import json

    from sessions.new.templates import new_session

    data = new_session("1/(s*(s+1)*(s+2))", "lead")
    for parameter in data["problem"]["parameters"]:
        parameter["value"] = {"K": 600.0, "T1": 1.0, "T2": 0.1}[parameter["name"]]
    data["problem"]["constraints"] = []
    path = tmp_path / "unstable.json"
    path.write_text(json.dumps(data))
    closed = np.roots(np.polyadd(np.polymul([1, 3, 2, 0], [0.1, 1]), [0, 0, 600.0, 600.0]))
    assert np.any(closed.real > 0)  # independently: unstable
    fig = sensitivity_figure(Workbench(load_session(path)).view())
    labels = [s.label for s in fig.series if s.label]
    assert "unbounded" in fig.title
    assert any(label.startswith("Ms unbounded") for label in labels)
    assert any("max|KS| unbounded" in label for label in labels)


def test_poles_of_one_damping_are_listed_by_frequency_whatever_their_last_bits():
    """Two modes of one damping (zeta = 0.01: a launch vehicle's bending modes) whose computed
    dampings differ in the last bits, either way round: listed by frequency, the slower first
    (a LAPACK build's rounding swapped them in the tableau's pole lines, and a snapshot failed)."""
    from types import SimpleNamespace

    from tui.figures.closed_loop import _listed_order

    def pole(re: float, im: float, zeta: float):
        return SimpleNamespace(value=complex(re, im), zeta=zeta, wn=abs(complex(re, im)))

    for tiny in (1e-17, -1e-17):
        fast, slow, lighter = pole(-0.24, 23.999, 0.01 + tiny), pole(-0.11, 10.999, 0.01), pole(-0.2, 23.9, 0.0088)
        listed = sorted([fast, slow, lighter], key=_listed_order)
        assert listed == [lighter, slow, fast]

"""Zoom, pan, cursor and reset never break a plot (issue 36, section 2): hypothesis drives
random sequences of the plot keys (one press, or one held up to 40 times) and mouse
events (wheel, drag, click) on every plot
kind (the Run tab's plots, the trajectories, History's views) at 120x40, 100x32 and
80x24; no exception may escape and no plot may say it cannot draw.

`make test` runs LOOPCRAFT_FUZZ_PLOT_CASES (default 2) sequences a size; `make fuzz`
runs 60."""

from __future__ import annotations

import asyncio
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from textual import events

from tests.fuzz.campaign import setting
from tui.app import LoopcraftApp
from tui.widgets.plots import FigurePlot

CASES = int(setting("PLOT_CASES", 2))
EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
SESSIONS = ("lead_sensitivity_peak", "projection_reactor", "coebra_launch_vehicle")
KEYS = ("plus", "minus", "h", "j", "k", "l", "left", "right", "shift+left", "shift+right", "0")
fraction = st.floats(0.0, 0.999)
actions = st.lists(
    st.one_of(
        st.tuples(st.just("plot"), st.integers(0, 8)),
        st.tuples(st.just("history"), st.integers(0, 7)),
        st.tuples(st.just("key"), st.sampled_from(KEYS)),
        st.tuples(st.just("held"), st.sampled_from(("plus", "minus", "h", "l")), st.integers(2, 40)),
        st.tuples(st.just("wheel"), st.booleans(), fraction, fraction),
        st.tuples(st.just("drag"), fraction, fraction, fraction, fraction),
        st.tuples(st.just("click"), fraction, fraction),
    ),
    min_size=5,
    max_size=25,
)


def _mouse(app, plot, kind, fx: float, fy: float, button: int = 0) -> None:
    """A mouse event at a fraction of the plot's content, sent as the terminal's driver does."""
    region = plot.content_region
    x, y = region.x + int(fx * region.width), region.y + int(fy * region.height)
    app.post_message(kind(None, x, y, 0, 0, button, False, False, False, screen_x=x, screen_y=y))


async def _act(app, pilot, action) -> None:
    kind, *args = action
    screen = app.screen
    if kind == "plot":
        screen.focus_main("run")
        tabs = screen.plot_tabs
        screen.query_one("#plots").active = tabs[args[0] % len(tabs)]
        await pilot.pause()
        await pilot.press("P")
    elif kind == "history":
        await pilot.press("4", *["o"] * args[0], "P")
    elif not isinstance(app.focused, FigurePlot):
        await pilot.press("P")
    if kind == "key" and isinstance(app.focused, FigurePlot):
        await pilot.press(args[0])
    if kind == "held" and isinstance(app.focused, FigurePlot):  # a key held: '-' 13 times killed the app
        await pilot.press(*[args[0]] * args[1])
    plot = app.focused if isinstance(app.focused, FigurePlot) else None
    if plot is None or plot.content_region.width == 0:
        return
    if kind == "wheel":
        _mouse(app, plot, events.MouseScrollUp if args[0] else events.MouseScrollDown, *args[1:])
    elif kind == "drag":
        _mouse(app, plot, events.MouseDown, *args[:2], button=1)
        _mouse(app, plot, events.MouseMove, *args[2:], button=1)
        _mouse(app, plot, events.MouseUp, *args[2:], button=1)
    elif kind == "click":
        _mouse(app, plot, events.MouseDown, *args, button=1)
        _mouse(app, plot, events.MouseUp, *args, button=1)


def _fresh(folder: Path, session: str) -> Path:
    """A fresh copy of an example (no autosave of an earlier case beside it to restore)."""
    case = Path(tempfile.mkdtemp(dir=folder))
    for f in EXAMPLES.iterdir():
        if f.suffix in (".json", ".csv"):
            shutil.copy2(f, case / f.name)
    return case / f"{session}.json"


def _broken(app) -> list[str]:
    """The plots on screen that cannot draw."""
    out = []
    for plot in app.screen.query(FigurePlot):
        if plot.display and plot.content_region.width > 0 and plot.content_region.height > 0:
            drawn = plot.render()
            if isinstance(drawn, str) and "cannot draw" in drawn:
                out.append(f"{plot.id} {plot.content_size}: {drawn}")
    return out


async def _drive(folder: Path, session: str, size: tuple[int, int], sequence) -> None:
    app = LoopcraftApp(_fresh(folder, session))
    async with app.run_test(size=size) as pilot:
        await pilot.pause()
        await app.workers.wait_for_complete()
        await pilot.press("s", "s")
        await app.workers.wait_for_complete()
        for k, action in enumerate(sequence):
            await _act(app, pilot, action)
            await pilot.pause()
            broken = _broken(app)
            assert not broken, (session, size, sequence[: k + 1], broken)
        await app.workers.wait_for_complete()
        await pilot.pause()
        assert not _broken(app), (session, size, sequence)


@pytest.mark.parametrize(
    "size",
    [pytest.param((120, 40), marks=pytest.mark.long), pytest.param((100, 32), marks=pytest.mark.long), (80, 24)],
    ids=["120x40", "100x32", "80x24"],
)
def test_random_plot_keys_and_mouse_never_break_a_plot(size, tmp_path_factory, monkeypatch):
    folder = tmp_path_factory.mktemp("plots")
    monkeypatch.setenv("LOOPCRAFT_HOME", str(folder / "home"))

    @settings(
        max_examples=CASES, deadline=None, database=None, suppress_health_check=list(HealthCheck), derandomize=False
    )
    @given(session=st.sampled_from(SESSIONS), sequence=actions)
    def check(session, sequence):
        asyncio.run(_drive(folder, session, size, sequence))

    check()

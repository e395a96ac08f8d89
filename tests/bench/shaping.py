"""Shaping latency (issue 38, section 2; part of `make bench`): a nudge of the lead's zero
in the shaping table (`C`, then `right` each time: one way, so every nudge is a design no cache
has seen; back and forth, every other press revisited a design and per-design caches answered it) on
1/(s^2 (s+10)) at 120x40 with the Bode plots shown: the key press to the end of the
first paint with the new tableau, and to the end of the paint after every plot is
drawn again (the first paint whose tableau is new).  Targets (issue 54, section 3): key to painted tableau <= 30 ms; key to
every visible plot repainted <= 120 ms on the lead, <= 250 ms on the tabulated launch
vehicle (`cip_launch_vehicle`, its first compensator's zero1: a root of cip's
polynomial, moved by its coefficients together).

A drag (issue 55, section 2): the same zeros' corner marks dragged along the Bode
magnitude by mouse events (one column right each move: one way, every frame a new design): each move to the
paint with the new tableau, and to the paint after the dragged plot is drawn again,
the frame (Bode's phase waits for the release); then a release one column on to the
paint after every plot on screen is drawn.  Targets: a frame <= 50 ms on the lead,
<= 100 ms on the tabulated launch vehicle; release to every plot exact <= 150 ms on the
lead."""

from __future__ import annotations

import asyncio
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from tests.bench.common import judged

TABLEAU_TARGET_S = 0.030  # a nudge: key to painted tableau (issue 54, section 3), either session
PLOTS_TARGET_S = {"lead": 0.120, "tabulated": 0.250}  # a nudge: key to every visible plot repainted
FRAME_TARGET_S = {"lead": 0.050, "tabulated": 0.100}  # a drag frame (issue 55, section 2)
RELEASE_TARGET_S = 0.150  # a drag's release to every plot, the lead
EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


async def _nudges(path: Path, presses: int, downs: int) -> tuple[list[float], list[float]]:
    from textual.screen import Screen

    from tui.app import LoopcraftApp

    app = LoopcraftApp(path)
    paints: list[float] = []
    painted_tableaux: list[object] = []  # the tableau's text at each paint (it may wait for its pole lines)
    refresh = Screen._compositor_refresh

    def noted(screen):
        refresh(screen)
        paints.append(time.perf_counter())
        tableau = app.screen.query_one_optional("#tableau")
        painted_tableaux.append(None if tableau is None else tableau.text)

    Screen._compositor_refresh = noted
    tableau_times, plot_times = [], []
    try:
        async with app.run_test(size=(120, 40)) as pilot:
            await pilot.pause()
            app.screen.query_one("#plots").active = "p-bode"
            await pilot.press("C")
            await app.workers.wait_for_complete()
            await pilot.pause()
            for _ in range(downs):  # to the zero
                await pilot.press("down")
                await app.workers.wait_for_complete()
                await pilot.pause()
            for _ in range(presses):
                before, shown = _values(app), app.screen.query_one("#tableau").text
                painted = len(paints)
                start = time.perf_counter()
                await pilot.press("right")  # one way: every nudge a design not seen before
                while _values(app) == before:
                    if time.perf_counter() - start > 5:
                        raise RuntimeError("a nudge changed nothing within 5 s")
                    await asyncio.sleep(0.001)
                new = []  # the paints since the key with a new tableau
                while not new and time.perf_counter() - start < 5:
                    await asyncio.sleep(0.001)
                    new = [t for t, text in zip(paints[painted:], painted_tableaux[painted:]) if text is not shown]
                tableau_times.append(new[0] - start)
                await app.workers.wait_for_complete()
                drawn = len(paints)
                while len(paints) == drawn and time.perf_counter() - start < 1:  # (plots may have painted already)
                    await asyncio.sleep(0.001)
                plot_times.append(paints[-1] - start)
                await pilot.pause()
    finally:
        Screen._compositor_refresh = refresh
    return tableau_times, plot_times


def _values(app) -> list:
    return [p.value for p in app.bench.session.model.problem.parameters]


def _sessions() -> tuple[Path, Path]:
    """A new lead session on 1/(s^2 (s+10)) and a copy of the tabulated launch vehicle, in a
    folder of their own (LOOPCRAFT_HOME there)."""
    from tui.cli import main

    folder = Path(tempfile.mkdtemp(prefix="loopcraft-bench-"))
    os.environ["LOOPCRAFT_HOME"] = str(folder / "home")
    lead = folder / "lead.json"
    main(["new", str(lead), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"])
    for name in ("cip_launch_vehicle.json", "cip_launch_vehicle.csv"):
        shutil.copy(EXAMPLES / name, folder / name)
    return lead, folder / "cip_launch_vehicle.json"


def nudge_latency(repeat: int) -> dict:
    """Medians of key to painted tableau and key to painted plots over ``repeat`` nudges,
    on the lead and on the tabulated launch vehicle."""
    lead, tabulated = _sessions()
    out = {}
    for label, path, downs in (("lead", lead, 1), ("tabulated", tabulated, 2)):
        tableau, plots = asyncio.run(_nudges(path, max(repeat, 5), downs))
        median, plotted = statistics.median(tableau), statistics.median(plots)
        out[label] = {
            "key_to_tableau_painted": {"median_s": median, **judged(median, TABLEAU_TARGET_S, "max_s")},
            "key_to_plots_painted": {"median_s": plotted, **judged(plotted, PLOTS_TARGET_S[label], "max_s")},
            "presses": len(tableau),
        }
    return out


class _Paints:
    """The end times of the app's paints (a screen's compositor refresh), while entered."""

    def __enter__(self) -> list[float]:
        from textual.screen import Screen

        self.refresh, self.times = Screen._compositor_refresh, []
        refresh, times = self.refresh, self.times

        def noted(screen):
            refresh(screen)
            times.append(time.perf_counter())

        Screen._compositor_refresh = noted
        return self.times

    def __exit__(self, *exc) -> None:
        from textual.screen import Screen

        Screen._compositor_refresh = self.refresh


async def _until(condition, start: float, limit: float = 5.0) -> None:
    while not condition():
        if time.perf_counter() - start > limit:
            raise RuntimeError(f"nothing happened within {limit} s")
        await asyncio.sleep(0.001)


def _mouse(plot, kind, cell: tuple[int, int]) -> None:
    content = plot.content_region
    sx, sy = content.x + cell[0], content.y + cell[1]
    plot.app.post_message(kind(None, sx, sy, 0, 0, 1, False, False, False, screen_x=sx, screen_y=sy))


def _noting_renders(plot) -> dict[str, float]:
    """The time the plot last drew a new figure (its render after `show`), as ``drawn[plot.id]``."""
    drawn: dict[str, float] = {}
    render, shown = plot.render, [plot.figure]

    def noted():
        out = render()
        if plot.figure is not shown[0]:
            shown[0] = plot.figure
            drawn[plot.id] = time.perf_counter()
        return out

    plot.render = noted
    return drawn


async def _drag(path: Path, moves: int) -> tuple[list[float], list[float], float]:
    """(move to tableau painted, move to dragged plot painted) per move, and release to
    every plot painted: each the end of the first paint after the change was drawn."""
    from textual import events

    from tui.app import LoopcraftApp

    app = LoopcraftApp(path)
    with _Paints() as paints:
        async with app.run_test(size=(120, 40)) as pilot:
            await pilot.pause()
            app.screen.query_one("#plots").active = "p-bode"
            await app.workers.wait_for_complete()
            await pilot.pause()
            plot, phase = app.screen.query_one("#bode-mag"), app.screen.query_one("#bode-phase")
            await _until(lambda: plot.figure.handles and plot.drawing is not None, time.perf_counter(), 30)
            await pilot.pause()
            drawn = _noting_renders(plot)
            phase_drawn = _noting_renders(phase)
            handle = next(h for h in plot.figure.handles if h.name.endswith(".zero1"))
            col, row = plot.drawing.frames[0].cells(handle.x, handle.y)
            cell = (round(col), round(row))
            _mouse(plot, events.MouseDown, cell)
            tableau, frames, release = [], [], 0.0
            for k in range(moves + 1):
                before, painted = _values(app), len(paints)
                drawn.clear()
                phase_drawn.clear()
                cell = (cell[0] + 1, cell[1])  # one way: every frame a design not seen before
                start = time.perf_counter()
                _mouse(plot, events.MouseUp if k == moves else events.MouseMove, cell)
                await _until(lambda: _values(app) != before, start)
                changed = time.perf_counter()  # (a paint before the edit, such as a text selection's, shows no tableau)
                await _until(lambda: paints[-1] >= changed if len(paints) > painted else False, start)
                tableau.append(next(t for t in paints[painted:] if t >= changed) - start)
                released = k == moves  # the phase panel follows on release alone
                await _until(lambda: plot.id in drawn and (phase.id in phase_drawn or not released), start)
                at = max(drawn[plot.id], phase_drawn.get(phase.id, 0.0))
                await _until(lambda: paints[-1] >= at, start)
                frames.append(next(t for t in paints if t >= drawn[plot.id]) - start)
                release = next(t for t in paints if t >= at) - start if released else release
                await app.workers.wait_for_complete()
                await pilot.pause()
    return tableau[:-1], frames[:-1], release


def drag_latency(repeat: int) -> dict:
    """Medians of a drag's move to painted tableau and to painted plot (the frame), and the
    release to every plot painted, on the lead and on the tabulated launch vehicle (each
    drag on new copies: a reopened session would first offer its autosave back)."""
    runs: dict[str, list[tuple[list[float], list[float], float]]] = {"lead": [], "tabulated": []}
    for _ in range(max(1, repeat // 5)):
        lead, tabulated = _sessions()
        runs["lead"].append(asyncio.run(_drag(lead, 6)))
        runs["tabulated"].append(asyncio.run(_drag(tabulated, 6)))
    out = {}
    for label, target in FRAME_TARGET_S.items():
        tableau = [t for run in runs[label] for t in run[0]]
        frames = [t for run in runs[label] for t in run[1]]
        median, release = statistics.median(frames), statistics.median(run[2] for run in runs[label])
        out[label] = {
            "move_to_tableau_painted": {"median_s": statistics.median(tableau)},
            "drag_frame": {"median_s": median, **judged(median, target, "max_s")},
            "release_to_plots_painted": {
                "median_s": release,
                **(judged(release, RELEASE_TARGET_S, "max_s") if label == "lead" else {}),
            },
            "moves": len(frames),
            "releases": len(runs[label]),
        }
    return out

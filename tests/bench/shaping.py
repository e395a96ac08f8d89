"""Shaping latency (issue 38, section 2; part of `make bench`): a nudge of the lead's zero
in the shaping table (`C`, `right`/`left` alternately, so the design does not drift) on
1/(s^2 (s+10)) at 120x40 with the Bode plots shown: the key press to the end of the
first paint with the new tableau, and to the end of the paint after every plot is
drawn again.  Targets: 50 ms median key to painted on a rational loop of order <= 20,
100 ms on the tabulated launch vehicle (`cip_launch_vehicle`, its first compensator's
zero1: a root of cip's polynomial, moved by its coefficients together)."""

from __future__ import annotations

import asyncio
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from tests.bench.common import judged

NUDGE_TARGET_S = 0.050
TABULATED_TARGET_S = 0.100
EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


async def _nudges(path: Path, presses: int, downs: int) -> tuple[list[float], list[float]]:
    from textual.screen import Screen

    from tui.app import LoopcraftApp

    app = LoopcraftApp(path)
    paints: list[float] = []
    refresh = Screen._compositor_refresh

    def noted(screen):
        refresh(screen)
        paints.append(time.perf_counter())

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
            for k in range(presses):
                before = _values(app)
                painted = len(paints)  # the edit is applied in the key's handler: the next paint shows it
                start = time.perf_counter()
                await pilot.press("right" if k % 2 == 0 else "left")
                while _values(app) == before:
                    if time.perf_counter() - start > 5:
                        raise RuntimeError("a nudge changed nothing within 5 s")
                    await asyncio.sleep(0.001)
                while len(paints) == painted and time.perf_counter() - start < 5:
                    await asyncio.sleep(0.001)
                tableau_times.append(paints[painted] - start)
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


def nudge_latency(repeat: int) -> dict:
    """Medians of key to painted tableau and key to painted plots over ``repeat`` nudges,
    on the lead and on the tabulated launch vehicle."""
    from tui.cli import main

    folder = Path(tempfile.mkdtemp(prefix="loopcraft-bench-"))
    os.environ["LOOPCRAFT_HOME"] = str(folder / "home")
    lead = folder / "lead.json"
    main(["new", str(lead), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"])
    for name in ("cip_launch_vehicle.json", "cip_launch_vehicle.csv"):
        shutil.copy(EXAMPLES / name, folder / name)
    out = {}
    for label, path, downs, target in (
        ("lead", lead, 1, NUDGE_TARGET_S),
        ("tabulated", folder / "cip_launch_vehicle.json", 2, TABULATED_TARGET_S),
    ):
        tableau, plots = asyncio.run(_nudges(path, max(repeat, 5), downs))
        median = statistics.median(tableau)
        out[label] = {
            "key_to_tableau_painted": {"median_s": median, **judged(median, target, "max_s")},
            "key_to_plots_painted": {"median_s": statistics.median(plots)},
            "presses": len(tableau),
        }
    return out

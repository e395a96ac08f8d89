"""Workbench latency (part of `make bench`): key press to the painted screen
with the new tableau and plots on the launch-vehicle CIP example at 120x40
(target 150 ms), and the longest wait of a 50 ms timer while a run goes
(target 100 ms)."""

from __future__ import annotations

import asyncio
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


def _workdir() -> Path:
    folder = Path(tempfile.mkdtemp(prefix="loopcraft-bench-"))
    os.environ["LOOPCRAFT_HOME"] = str(folder / "home")
    for f in EXAMPLES.iterdir():
        if f.suffix in (".json", ".csv"):
            shutil.copy2(f, folder / f.name)
    return folder


async def _step_latency(folder: Path, presses: int) -> list[float]:
    """From the key press to the end of the first paint after the app has
    taken the new iteration (the screen's compositor refresh), per press."""
    from textual.screen import Screen
    from tui.app import LoopcraftApp
    app = LoopcraftApp(folder / "cip_launch_vehicle.json")
    shown, painted = [False], []
    stepped, refresh = app._stepped, Screen._compositor_refresh

    def stepped_and_noted(*args, **kwargs):
        stepped(*args, **kwargs)
        shown[0] = True

    def refresh_and_noted(screen):
        refresh(screen)
        if shown[0]:
            painted.append(time.perf_counter())
            shown[0] = False

    app._stepped = stepped_and_noted
    Screen._compositor_refresh = refresh_and_noted
    samples = []
    try:
        async with app.run_test(size=(120, 40)) as pilot:
            await pilot.pause()
            for _ in range(presses):
                before, start = len(painted), time.perf_counter()
                await pilot.press("s")
                while len(painted) == before and time.perf_counter() - start < 5.0:
                    await asyncio.sleep(0.002)
                await app.workers.wait_for_complete()
                samples.append(painted[-1] - start)
                await pilot.pause()
    finally:
        Screen._compositor_refresh = refresh
    return samples


async def _timer_gaps(folder: Path, seconds: float) -> list[float]:
    from tui.app import LoopcraftApp
    app = LoopcraftApp(folder / "cip_dual_channel.json")
    ticks: list[float] = []
    async with app.run_test(size=(120, 40)) as pilot:
        await pilot.pause()
        app.set_interval(0.05, lambda: ticks.append(time.perf_counter()))
        await pilot.press("r")
        await pilot.pause(seconds)
        await pilot.press("space")
        await app.workers.wait_for_complete()
    return [b - a for a, b in zip(ticks, ticks[1:])]


def measure(presses: int = 15, run_seconds: float = 2.0) -> dict:
    folder = _workdir()
    latency = asyncio.run(_step_latency(folder, presses))
    gaps = asyncio.run(_timer_gaps(_workdir(), run_seconds))
    return {"step_to_screen": {"median_s": statistics.median(latency), "max_s": max(latency), "target_s": 0.150,
                               "presses": presses, "terminal": "120x40", "session": "cip_launch_vehicle"},
            "timer_50ms_during_run": {"max_wait_s": max(gaps) if gaps else None, "target_s": 0.100,
                                      "ticks": len(gaps) + 1}}


if __name__ == "__main__":
    import json
    print(json.dumps(measure(), indent=2))

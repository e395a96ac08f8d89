"""The worker computes, the screen commits: keys that change the session are
disabled while a run goes, so pressing them during a run (undo above all,
which corrupted the history when the worker appended records itself) can
never leave a session that does not replay.

The keys are sent the way a terminal sends them, without waiting for the
app to be idle (the pilot's `press` waits, and a run keeps the app busy
until it ends), so they land between the run's records."""

from __future__ import annotations

import asyncio
import os
import random
import time

import pytest
from textual import events

from engine.cip import Cip
from sessions.runner import replay
from sessions.store import load_session
from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp

TRIALS = 24
STEP_SECONDS = 0.004  # each iteration made this much slower, so a run outlasts the keys
MUTATING_KEYS = ("z", "s", "r", "a", "w", "u", "n", "b", "e", "f", "g", "plus", "minus", "x", "c", "i", "ctrl+o")
CHARACTERS = {"plus": "+", "minus": "-", "space": " "}


async def send_keys(app, *keys: str) -> None:
    """Key events as the terminal sends them, a few milliseconds apart."""
    for key in keys:
        event = events.Key(key, CHARACTERS.get(key, key if len(key) == 1 else None))
        event.set_sender(app)
        app._driver.send_message(event)
        await asyncio.sleep(0.003)


def _consistent(bench) -> None:
    """Record k carries iteration k, the model and the workbench agree."""
    records = bench.session.model.records
    assert bench.iteration == len(records) == len(bench.records)
    assert [r["iteration"] for r in records] == list(range(1, len(records) + 1))


@pytest.mark.long
@synchronous
async def test_keys_pressed_during_runs_never_corrupt_the_history(workdir, monkeypatch):
    step = Cip.step

    def slow_step(self, state):
        time.sleep(STEP_SECONDS)
        return step(self, state)

    monkeypatch.setattr(Cip, "step", slow_step)
    rng = random.Random(int(os.environ.get("LOOPCRAFT_RACE_SEED", "7")))  # another seed: another key sequence
    path = workdir / "cip_dual_channel.json"
    app = LoopcraftApp(path)
    refused = []
    check = app.check_action

    def spy(action, parameters):
        verdict = check(action, parameters)
        if app.busy and action == "undo":
            refused.append(verdict)
        return verdict

    app.check_action = spy
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        for _ in range(TRIALS):
            if app.bench.status().finished:
                app.bench.start_from(app.bench.iteration // 2)
                app.refresh_workbench()
            await send_keys(app, "r")
            await asyncio.sleep(rng.uniform(0.0, 0.05))
            await send_keys(app, *rng.sample(MUTATING_KEYS, 5), "z", "z", "space")
            await settle(app, pilot)
            while len(app.screen_stack) > 2:  # a dialog opened after the run ended: close it
                await pilot.press("escape")
            _consistent(app.bench)
            if rng.random() < 0.5:
                await pilot.press("z")
                await settle(app, pilot)
                _consistent(app.bench)
        await pilot.press("ctrl+s")
        await settle(app, pilot)
    assert refused and all(verdict is None for verdict in refused)  # undo came during runs, and was disabled
    result = replay(load_session(path))
    assert result.ok, result.message
    assert result.iterations == len(load_session(path).model.records) > 0

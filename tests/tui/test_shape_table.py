"""Shaping by hand in the workbench (issue 38, sections 1 and 3): C shows the compensator's
items under the tableau; left/right move the selected one, e types it, g and G solve the
loop gain exactly; a burst of nudges on one item is one undo step; every result checked
against python-control on the design the keys made."""

from __future__ import annotations

import math

import control as ct
import pytest

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp
from tui.cli import main

PLANT = ct.tf([1], [1, 10, 0, 0])


def _values(app) -> dict[str, float]:
    return {p.name: p.value for p in app.bench.session.model.problem.parameters}


def _loop(values) -> ct.TransferFunction:
    return ct.tf([values["K"] * values["T1"], values["K"]], [values["T2"], 1]) * PLANT


def _lead_app(tmp_path, monkeypatch) -> LoopcraftApp:
    """The app on a new lead session for 1/(s^2 (s+10)): K*(1+T1*s)/(1+T2*s)."""
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s^2*(s+10))", "--compensator", "lead"]) == 0
    return LoopcraftApp(path)


async def _typed(app, pilot, key: str, text: str) -> None:
    await pilot.press(key)
    await pilot.pause()
    app.screen.query_one("#value").value = text
    await pilot.press("enter")
    await settle(app, pilot)


@synchronous
async def test_a_lead_shaped_by_keys(tmp_path, monkeypatch):
    app = _lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        await pilot.press("C")
        await settle(app, pilot)
        table = app.screen.query_one("#shape")
        assert app.focused is table and table.names == ["compensator.gain", "compensator.zero1", "compensator.pole1"]
        await _typed(app, pilot, "g", "1")  # the gain for a 1 rad/s crossover
        assert abs(_loop(_values(app))(1j)) == pytest.approx(1.0, rel=1e-10)
        assert table.check_action("damp", ()) is None  # the gain is no pair: [ ] disabled
        await pilot.press("down")
        before = _values(app)
        await pilot.press(*["left"] * 6)  # the zero 5 % lower, six times: one burst
        await settle(app, pilot)
        after = _values(app)
        assert after["T1"] == pytest.approx(before["T1"] * 1.05**6, rel=1e-9) and after["K"] == before["K"]
        assert app.bench.edits.last.startswith("edit: T1 value: 1 -> 1.34")
        await _typed(app, pilot, "G", "45")  # then the gain for a 45 deg phase margin
        _, pm, _, _, wc, _ = ct.stability_margins(_loop(_values(app)))
        assert pm == pytest.approx(45.0, abs=1e-6) and wc > 1.0
        await pilot.press("down")
        await _typed(app, pilot, "e", "12")  # the pole typed at 12 rad/s (the session keeps T1 <= 20 T2)
        assert _values(app)["T2"] == pytest.approx(1 / 12, rel=1e-10)
        for _ in range(3):  # the pole, the PM gain, the burst: three undo steps
            await pilot.press("ctrl+z")
            await settle(app, pilot)
        assert _values(app)["T1"] == before["T1"] and _values(app)["K"] == before["K"]


TUTORIAL = ["C", "g", "1", "enter", "down"]  # docs/tutorial.md, "Shaping a lead by hand"


@synchronous
async def test_the_tutorials_lead_takes_well_under_thirty_keys(tmp_path, monkeypatch):
    """The issue's lead for 1/(s^2 (s+10)) by hand: the gain for a 1 rad/s crossover, then the
    zero nudged down until PM >= 45 deg (python-control's margins of the design on screen)."""
    app = _lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        keys = 0
        for key in TUTORIAL:
            if key == "1":
                app.screen.query_one("#value").value = "1"
            else:
                await pilot.press(key)
            keys += 1
            await settle(app, pilot)
        while ct.stability_margins(_loop(_values(app)))[1] < 45 and keys < 30:
            await pilot.press("left")
            await settle(app, pilot)
            keys += 1
        gm, pm, _, _, wc, _ = ct.stability_margins(_loop(_values(app)))
        print(f"keys {keys}: PM {pm:.2f} deg, GM {20 * math.log10(gm):.2f} dB, crossover {wc:.4g} rad/s")
        assert pm >= 45 and keys == 12 and 20 * math.log10(gm) >= 8 and wc >= 1.0

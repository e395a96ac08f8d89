"""docs/tutorial.md as a pilot test: a lead compensator for 10/(s(s+1)(s+5)) with
PM >= 50 deg, GM >= 10 dB and a crossover of at least 3 rad/s, from nothing, in
fewer than 100 keys; python-control confirms the design."""

from __future__ import annotations

import math
import re
from pathlib import Path

import control as ct

from tests.tui.test_app import settle, synchronous
from tui.app import LoopcraftApp

# the key sequence of docs/tutorial.md, one entry per key press (text typed counts a key per character)
TUTORIAL = (
    ["n", "enter"]
    + list("10/(s*(s+1)*(s+5))")
    + ["enter", "enter"]  # new session: unity, plant, lead
    + ["3", "e", "enter", "ctrl+u"]
    + list("50")
    + ["enter"]  # PM target 50 deg
    + ["down", "e", "enter", "ctrl+u"]
    + list("10")
    + ["enter"]  # GM target 10 dB
    + ["plus"]
    + ["down"] * 6
    + ["enter"]  # a crossover target
    + ["down", "e", "enter", "ctrl+u"]
    + list("3")
    + ["enter"]  # at least 3 rad/s
    + ["r", "1"]
)  # run slp to the end


@synchronous
async def test_the_tutorial_designs_a_lead_compensator_in_under_100_keys(tmp_path, monkeypatch):
    monkeypatch.setenv("LOOPCRAFT_HOME", str(tmp_path / "home"))
    app = LoopcraftApp()
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        for key in TUTORIAL:
            await pilot.press(key)
            await pilot.pause()
            if key == "r":
                await settle(app, pilot)
        await settle(app, pilot)
        bench = app.bench
        assert len(TUTORIAL) < 100
        targets = {t.measure: t.bands[0].desired for t in bench.session.model.problem.targets}
        assert targets == {"phase_margin_deg": 50.0, "gain_margin_db": 10.0, "crossover_frequency": 3.0}
        assert bench.records and bench.records[-1].status.finished
        values = bench.records[-1].parameters
        s = ct.tf("s")
        loop = values["K"] * (1 + values["T1"] * s) / (1 + values["T2"] * s) * 10 / (s * (s + 1) * (s + 5))
        gm, pm, _, wc = ct.margin(loop)
        assert pm >= 50 - 1e-6 and 20 * math.log10(gm) >= 10 - 1e-6 and wc >= 3 - 1e-9, (values, gm, pm, wc)
        assert bench.records[-1].status.value == "converged"
        page = _closing_numbers()
        shown = {
            "iterations": bench.iteration,
            "K": values["K"],
            "T1": values["T1"],
            "T2": values["T2"],
            "PM": pm,
            "GM": 20 * math.log10(gm),
            "crossover": wc,
        }
        for name, text in page.items():  # the page says what the app shows, to the digits it shows
            decimals = len(text.split(".")[1]) if "." in text else 0
            assert round(shown[name], decimals) == float(text), (name, text, shown[name])


def _closing_numbers() -> dict[str, str]:
    """The numbers docs/tutorial.md gives for the design the run ends with."""
    page = (Path(__file__).resolve().parents[2] / "docs" / "tutorial.md").read_text()
    found = re.search(
        r"slp converges in (\d+) iterations to K = ([\d.]+), T1 = ([\d.]+), T2 = ([\d.]+): PM ([\d.]+) deg,\s+"
        r"GM ([\d.]+) dB, crossover ([\d.]+) rad/s",
        page,
    )
    assert found, "the tutorial's closing sentence"
    return dict(zip(("iterations", "K", "T1", "T2", "PM", "GM", "crossover"), found.groups()))

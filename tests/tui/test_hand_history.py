"""Hand moves in the history (issue 38, section 3): a nudge after iterations keeps the run
that led there as an earlier stage and notes the hand move, the History tab shows both,
the next run starts afresh from the hand design, and `replay` reproduces the earlier
run's iterations on its own start as well as the current run's."""

from __future__ import annotations

import pytest

from sessions.runner import replay
from tests.tui.test_app import settle, synchronous
from tests.tui.test_shape_table import lead_app, start_values
from tui.screens.dialogs import StartDialog


@pytest.mark.long
@synchronous
async def test_a_hand_move_between_runs_is_kept_shown_and_replayed(tmp_path, monkeypatch):
    app = lead_app(tmp_path, monkeypatch)
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        for _ in range(2):
            await pilot.press("s")
            await settle(app, pilot)
        run_end = dict(app.bench.records[-1].parameters)
        await pilot.press("C")
        await settle(app, pilot)
        await pilot.press("down", "right")  # the zero, 5 % up
        await pilot.pause()
        if isinstance(app.screen, StartDialog):  # the session's first such edit asks
            await pilot.press("y")
        await settle(app, pilot)
        await pilot.press("right")  # the same burst: joined to the same hand move
        await settle(app, pilot)
        earlier = app.bench.session.model.earlier
        assert [s.kind for s in earlier] == ["run", "hand"] and len(earlier[0].records) == 2
        (change,) = earlier[1].changes
        assert change.name == "T1" and change.before == pytest.approx(run_end["T1"], rel=1e-12)
        assert change.after == pytest.approx(run_end["T1"] / 1.05**2, rel=1e-9)  # the zero up twice by 5 %
        assert start_values(app)["T1"] == change.after and app.bench.iteration == 0
        await pilot.press("s")  # a new run, from the hand design
        await settle(app, pilot)
        assert app.bench.iteration == 1
        await pilot.press("4")  # History
        await settle(app, pilot)
        lines = app.screen.query_one("#history-earlier").text.plain.splitlines()
        assert lines[0].startswith("run 1: ") and "iterations 1-2" in lines[0]
        assert lines[1].startswith("hand: T1: ") and "starts from there" in lines[2]
        result = replay(app.bench.session)
        assert result.ok, result.message
        assert "the 2 iterations of 1 earlier run(s), with 1 hand move(s) between" in result.message
        earlier[1].changes[0].after *= 1.001  # a broken chain is found
        assert "do not lead from one to the next" in replay(app.bench.session).message

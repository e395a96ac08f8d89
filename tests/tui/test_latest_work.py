"""Only the latest request waits (issue 38, section 2): while a computation runs, a held
key's requests replace one another, so the designs passed over are never computed and
no thread piles up; the root locus comes coarse first, then refined."""

from __future__ import annotations

import threading

from textual import on
from textual.app import App

from tests.tui.test_app import settle, synchronous
from tui.screens.latest_work import LatestWork


class Owner(App):
    errors: list[str] = []

    @on(LatestWork.Done)
    def _done(self, message: LatestWork.Done) -> None:  # what an owner does
        message.work.done()
        if message.error is not None:
            self.errors.append(message.error)


@synchronous
async def test_requests_made_while_one_runs_leave_only_the_latest_waiting():
    app = Owner()
    release = threading.Event()
    ran: list[int] = []

    def job(n: int):
        def compute() -> None:
            if n == 0:
                release.wait(5)
            ran.append(n)

        return compute

    async with app.run_test() as pilot:
        work = LatestWork(app, "test")
        for n in range(30):  # a held key
            work.request(job(n), n)
        work.request(job(29), 29)  # the same design again: dropped
        release.set()
        await app.workers.wait_for_complete()
        await pilot.pause()
        await app.workers.wait_for_complete()
        assert ran == [0, 29] and work.running is None and work.waiting is None

        def broken() -> None:
            raise ValueError("no figure")

        work.request(broken, "bad")
        await app.workers.wait_for_complete()
        await pilot.pause()
        assert app.errors == ["ValueError: no figure"] and work.running is None  # said, and the app goes on


@synchronous
async def test_the_root_locus_comes_coarse_first_then_refined(workdir):
    from tui.app import LoopcraftApp

    app = LoopcraftApp(workdir / "report003_lag_lead.json")
    titles: list[str] = []
    async with app.run_test(size=(120, 40)) as pilot:
        await settle(app, pilot)
        screen = app.screen
        shown = screen.view_actions.locus_drawn

        def noted(message) -> None:
            titles.append(message.figure.title)
            shown(message)

        screen.view_actions.locus_drawn = noted
        screen.query_one("#plots").active = "p-locus"
        await settle(app, pilot)
        await app.workers.wait_for_complete()
        await settle(app, pilot)
        assert len(titles) == 2 and titles[0].endswith("(coarse: refining ...)") and "coarse" not in titles[1]

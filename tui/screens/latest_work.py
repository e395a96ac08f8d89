"""One computation at a time in a thread worker, and only the latest request waiting:
while a key is held (a nudge thirty times a second) the figures of the designs passed
over are never computed, and no thread piles up behind another (a thread worker cannot
be stopped midway, so an exclusive worker per request would run them all at once).
And when a drag's frame is quick enough to be drawn at once instead (`FrameTimes`)."""

from __future__ import annotations

import math
from collections.abc import Callable

from textual.dom import DOMNode
from textual.message import Message


class LatestWork:
    """Requests run one at a time on ``owner``'s thread workers of ``group``; a request
    made while one runs replaces the one waiting, and a request for what is running or
    waiting already (the same ``key``) is dropped.  The owner handles `Done` by calling
    `done`."""

    def __init__(self, owner: DOMNode, group: str) -> None:
        self.owner, self.group = owner, group
        self.running: object = None  # the key of the computation running (None: none)
        self.waiting: tuple[object, Callable[[], None]] | None = None

    def request(self, compute: Callable[[], None], key: object = True) -> None:
        """Run ``compute`` now, or after the running one (replacing any waiting)."""
        if self.running is None:
            self._start(key, compute)
        elif key == self.running:
            self.waiting = None  # back to the design being computed: the one waiting is stale
        elif self.waiting is None or key != self.waiting[0]:
            self.waiting = (key, compute)

    class Done(Message):
        """A computation of ``work`` finished (posted by its thread to the owner, whose
        handler calls `LatestWork.done`, once: it does not bubble); ``error``: what it
        raised, if it failed."""

        bubble = False

        def __init__(self, work: LatestWork, error: str | None = None) -> None:
            super().__init__()
            self.work, self.error = work, error

    def _start(self, key: object, compute: Callable[[], None]) -> None:
        self.running = key
        owner = self.owner

        def run() -> None:
            try:
                compute()
            except Exception as exc:  # noqa: BLE001 - a figure that cannot be made must not end the app
                owner.post_message(self.Done(self, f"{type(exc).__name__}: {exc}"))
            else:
                owner.post_message(self.Done(self))

        owner.run_worker(run, thread=True, group=self.group, exit_on_error=False)

    def done(self) -> None:
        """(UI thread, on `Done`) The running one finished: the waiting one, if any, runs next."""
        self.running = None
        if self.waiting is not None:
            (key, compute), self.waiting = self.waiting, None
            self._start(key, compute)


INLINE_FRAME_S = 0.025  # a drag's frame drawn on the UI thread when the plot's last one took at most this


class FrameTimes:
    """How long each plot's last drag frame took to draw, and so whether the next is drawn
    on the UI thread, at once, rather than by a worker.  A worker's frame waits for a
    paint of its own (the tableau painted first, then the plot: two waits on Textual's
    60 Hz tick); a frame drawn at once is painted with the tableau.  A plot's first
    frame, of unknown cost, goes to the worker, as does one after a frame slower than
    `INLINE_FRAME_S` (a few ms on the lead and on the tabulated launch vehicle) or one
    that raised."""

    def __init__(self) -> None:
        self._seconds: dict[str, float] = {}  # plot id -> its last drag frame's drawing time

    def at_once(self, names: set[str] | frozenset[str], work: LatestWork) -> bool:
        """Whether the frames of these plots are drawn now (no drawing of ``work`` under way)."""
        if work.running is not None:
            return False
        return all(self._seconds.get(name, math.inf) <= INLINE_FRAME_S for name in names)

    def took(self, names: set[str] | frozenset[str], seconds: float) -> None:
        """A frame of these plots was drawn in ``seconds`` of its thread's time (math.inf: it failed)."""
        self._seconds.update(dict.fromkeys(names, seconds))

    def forget(self, name: str) -> None:
        """A drag of this plot begins: its first frame's cost is unknown again (a part added,
        another condition or locus parameter since the last drag may have changed it)."""
        self._seconds.pop(name, None)

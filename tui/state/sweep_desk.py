"""The Workbench's sweeps: the session's latest sweep (its JSON data, dumped once), a sweep run
from one line in a worker, its summary kept on the UI thread, and a design adopted from it
(the best optimum, or a tolerance study's worst sample) as the new start."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from sessions.errors import SessionError
from sessions.format.schema import SweepModel
from sessions.sweeps.jobs import execute
from sessions.sweeps.plan import parse_sweep, plan
from sessions.sweeps.results import summarize

if TYPE_CHECKING:
    from tui.state.workbench import Workbench


class SweepDesk:
    """One workbench's sweeps (``bench.sweeps``)."""

    def __init__(self, bench: Workbench) -> None:
        self._bench = bench
        self._data: tuple[SweepModel, dict] | None = None  # the latest sweep and its JSON data

    def latest(self) -> dict | None:
        """The session's most recent sweep (JSON data), if any: the same dict while it is the
        same sweep (dumped once: the Sweep tab reads it at every refresh)."""
        sweeps = self._bench.session.model.sweeps
        if not sweeps:
            return None
        if self._data is None or self._data[0] is not sweeps[-1]:
            self._data = (sweeps[-1], sweeps[-1].model_dump())
        return self._data[1]

    def run(
        self,
        text: str,
        progress: Callable[[int, int], None] | None = None,
        cancelled: Callable[[], bool] = lambda: False,
    ) -> dict:
        """Plan and run a sweep described by one line (`sessions.sweeps.plan.parse_sweep`);
        safe in a worker thread while the session is not changed (the app disables
        every change during a sweep).  The summary is returned, not yet kept:
        `keep` does that on the UI thread."""
        session = self._bench.session
        spec = parse_sweep(text)
        jobs, settings = plan(
            session,
            spec["kind"],
            spec["value"],
            spec.get("spread"),
            spec.get("seed", 0),
            spec.get("samples", 32),
            spec.get("sampling", "random"),
        )
        settings["scheduler"] = spec["scheduler"] or "local"
        outcome = execute(jobs, spec["scheduler"], progress=progress, cancelled=cancelled)
        return summarize(session, spec["kind"], settings, outcome)

    def keep(self, summary: dict) -> None:
        """Record a sweep's summary in the session (UI thread)."""
        self._bench.book.keep_sweep(summary)

    def adopt_best(self) -> dict:
        """Make the latest sweep's best optimum the start (records dropped); its run."""
        sweep = self.latest()
        if not sweep or not sweep["optima"]:
            raise SessionError("no sweep with a finished run to adopt")
        run = sweep["runs"][sweep["optima"][0]["best_run"]]
        widened = self._bench.book.adopt_run(run)
        return {**run, "widened": widened}

    def adopt_worst(self, row: int) -> dict:
        """Make the worst sample of a row of the latest tolerance study's worst case the
        start, to look at (records dropped); its run, with the row."""
        sweep = self.latest()
        if not sweep or sweep["kind"] != "tolerance" or not 0 <= row < len(sweep["worst_case"]):
            raise SessionError("no row of a tolerance study to adopt the worst sample of")
        chosen = sweep["worst_case"][row]
        run = next(r for r in sweep["runs"] if r["index"] == chosen["worst_sample"])
        widened = self._bench.book.adopt_run(run)
        return {**run, "row": chosen, "widened": widened}

    def refusal(self) -> str | None:
        """Why the latest sweep has no design to adopt (None: it has)."""
        sweep = self.latest()
        if sweep is None:
            return "no sweep yet (w starts one)"
        if sweep["kind"] == "tolerance":
            return None if sweep["worst_case"] else "no sample of the tolerance study finished"
        return None if sweep["optima"] else "no run of the sweep finished"

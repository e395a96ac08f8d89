"""How `projection` records are shown: the convergence is the distance
between the two sets (log10), the plots are the trajectories (the current
iterate's, and the untrimmed open loop the first record carries)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from engine.stepping.presenter import Presenter
from engine.stepping.protocol import State, Stepper, StepRecord


class ProjectionPresenter(Presenter):
    """Report 004's iterates: no loop to draw, trajectories instead."""

    plots = frozenset({"convergence", "trajectories"})

    def initial_record(self, stepper: Stepper, state: State) -> StepRecord:
        return stepper.initial_record(state)  # its own stepper's, which knows the record's layout

    def convergence(self, record: StepRecord) -> tuple[str, float | None]:
        distance = record.extra.get("distance")
        return "log10 distance between the sets", None if distance is None else math.log10(max(distance, 1e-300))

    def trajectories(self, records: Sequence[StepRecord]) -> dict | None:
        if not records or "u" not in records[-1].extra:
            return None
        e = records[-1].extra
        data = {"t": e["t"], "x": e["x"], "u": e["u"], "current": e}
        initial = records[0].extra.get("open_loop")
        if initial is not None:
            data["open_loop"] = initial
        return data

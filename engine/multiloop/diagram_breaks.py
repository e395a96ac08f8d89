"""Every break of one block diagram's condition, in one call: at each break the loop broken there
with every other loop closed (its gain and phase margins at every crossing and its disk margin, by
the single-loop search), the closed loop's stability read once (the same closed loop at every
break), and the multi-loop disk margin at all of them at once
(`engine.multiloop.network_breaks.diagram_disk_margin`).  A break, or the multi-loop margin, that
cannot be computed carries its reason instead.  The report, the exports' checks and the
workbench's lines under the tableau all read this."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from numpy.typing import ArrayLike

from engine.analysis import closed_loop_peaks, margins_with_peaks
from engine.closed_loop.poles import closed_loop_verdict, delayed_verdict
from engine.errors import EngineError
from engine.loop.responses import loop_model
from engine.margins.disk import DiskMargin
from engine.margins.search import Margins
from engine.model.network import Network
from engine.multiloop.delay_stability import Verdict
from engine.multiloop.disk import MultiLoopDiskMargin
from engine.multiloop.network_breaks import diagram_disk_margin


@dataclass(frozen=True)
class BreakLoop:
    """The loop at one break: its margins and disk margin, or why it cannot be analyzed."""

    name: str
    margins: Margins | None
    disk_margin: DiskMargin | None
    failure: str | None = None


@dataclass(frozen=True)
class DiagramBreaks:
    """Every break of a condition (module docstring); ``verdict``: the closed loop's stability
    ('stable', 'unstable', 'marginally stable' or 'unknown')."""

    verdict: str
    loops: tuple[BreakLoop, ...]
    together: MultiLoopDiskMargin | None
    together_failure: str | None = None


def diagram_breaks(
    network: Network, breaks: Sequence[str], omega: ArrayLike, params: Mapping[str, float]
) -> DiagramBreaks:
    """The loops at ``breaks`` one at a time and all together (module docstring)."""
    verdict, counted = _verdict(network, params)
    loops = tuple(_break_loop(network, name, omega, params, verdict) for name in breaks)
    try:
        return DiagramBreaks(verdict, loops, diagram_disk_margin(network, breaks, dict(params), stability=counted))
    except EngineError as exc:
        return DiagramBreaks(verdict, loops, None, str(exc))


def _verdict(network: Network, params: Mapping[str, float]) -> tuple[str, Verdict | None]:
    """The closed loop's verdict, and for a loop with delays the argument count it rests on (counted once:
    the multi-loop margin takes it, the same closed loop whatever the breaks)."""
    if network.rational:
        return closed_loop_verdict(network, params), None
    status, note = delayed_verdict(network, params)
    return status, Verdict("undecided" if status == "unknown" else status, note)


def _break_loop(network: Network, name: str, omega: ArrayLike, params: Mapping[str, float], verdict: str) -> BreakLoop:
    try:
        model = loop_model(network, name, omega, params)
        found, peaks = margins_with_peaks(model, 0.0)
        disk, *_ = closed_loop_peaks(model, verdict, found=peaks)
        return BreakLoop(name, found, disk)
    except EngineError as exc:
        return BreakLoop(name, None, None, str(exc))

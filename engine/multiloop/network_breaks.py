"""Several breaks of a block diagram at once: every named signal of ``breaks`` cut, each use of
it fed by a new input instead (as `engine.loop.pole_zero.broken_network` cuts one), and the
realization of that network (`engine.loop.realization.realize`) read as a square plant under
unity negative feedback: the returns x_breaks = R u, so L = -R (L u = y, u = -y closes every
break again).  The multi-loop disk margin at the breaks is that plant's
(`engine.multiloop.disk`); a diagram in z is realized in w (its frequency brought back to rad/s);
one with delays is cut at them too, the delays evaluated exactly (`engine.multiloop.delayed`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from engine.errors import EngineError
from engine.loop.realization import StateSpace, realize, realize_opened
from engine.model.bilinear import real_frequency
from engine.model.blocks import DelayTransfer, TabulatedTransfer
from engine.model.network import Network
from engine.multiloop.delay_stability import Verdict
from engine.multiloop.delayed import delayed_disk_margin
from engine.multiloop.disk import MultiLoopDiskMargin, multi_loop_disk_margin
from engine.multiloop.plant import Plant, balanced_plant


def broken_at(network: Network, breaks: Sequence[str]) -> Network:
    """The network with every use of each of ``breaks`` fed by a new input "break NAME" instead."""
    if len(set(breaks)) != len(breaks):
        raise EngineError(f"breaks {', '.join(breaks)}: a signal is named twice")
    n = len(network.signals)
    column = {network.signal(name): n + j for j, name in enumerate(breaks)}
    entries = tuple(replace(e, col=column[e.col]) if e.col in column else e for e in network.entries)
    names = tuple(f"break {name}" for name in breaks)
    return Network(network.signals + names, network.inputs + names, entries, network.variable, network.sample_time)


def refused_blocks(network: Network) -> str | None:
    """Why the multi-loop disk margin is not computed on ``network`` (None: it can be): its tables (a table
    has no realization: loop at a time only), named."""
    named = list(dict.fromkeys(e.label for e in network.entries if isinstance(e.transfer, TabulatedTransfer)))
    if named:
        return (
            f"table block(s) {', '.join(named)}: a table has no realization, so its loops are analyzed "
            "one at a time only (the multi-loop disk margin needs the diagram's state space)"
        )
    return None


def breaks_plant(network: Network, breaks: Sequence[str], params: Mapping[str, float]) -> tuple[Plant, float | None]:
    """(the loop matrix at ``breaks`` as a plant, the diagram's sample time: its realization is in w then);
    an `EngineError` naming a diagram's tables (`refused_blocks`) or delays (`diagram_disk_margin` takes them)."""
    refused = refused_blocks(network)
    if refused is not None:
        raise EngineError(refused)
    return _plant(realize(broken_at(network, breaks), params), breaks)


def _plant(ss: StateSpace, breaks: Sequence[str]) -> tuple[Plant, float | None]:
    """The loop matrix at ``breaks`` of the realization ``ss`` of the diagram cut there, as a plant."""
    columns = [ss.inputs.index(f"break {name}") for name in breaks]
    rows = [ss.outputs.index(name) for name in breaks]
    plant = Plant(ss.A, ss.B[:, columns], -ss.C[rows], -ss.D[np.ix_(rows, columns)], tuple(breaks))
    return balanced_plant(plant), ss.sample_time


def diagram_disk_margin(
    network: Network,
    breaks: Sequence[str],
    params: Mapping[str, float],
    skew: float = 0.0,
    stability: Verdict | None = None,
) -> MultiLoopDiskMargin:
    """The multi-loop disk margin at the diagram's ``breaks`` (module docstring); ``stability``: the
    closed loop's verdict with its delays when the caller has it (`engine.multiloop.delayed`)."""
    if any(isinstance(e.transfer, DelayTransfer) for e in network.entries) and refused_blocks(network) is None:
        opened = realize_opened(broken_at(network, breaks), params)
        if opened.taus:
            return delayed_disk_margin(opened, tuple(breaks), skew, stability)
        plant, sample_time = _plant(opened.ss, breaks)
    else:
        plant, sample_time = breaks_plant(network, breaks, params)
    found = multi_loop_disk_margin(plant, skew)
    if sample_time is None:
        return found
    omega = (
        math.pi / sample_time if found.frequency == math.inf else float(real_frequency(found.frequency, sample_time))
    )
    note = f"a diagram in z (sample time {sample_time:g} s): searched on its w-plane form, the frequency in rad/s"
    return replace(found, frequency=omega, notes=found.notes + (note,))

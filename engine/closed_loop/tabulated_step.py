"""The step response of a continuous loop with tabulated blocks, from rational models of its tables,
with the error each measure carries.

Each table is replaced by its rational model (`engine.loop.table_model`: the AAA fit, far right-half-
plane roots dropped, its residual measured on the table) and the loop of models stepped as
`step_response.network_step` steps it: exactly, its measures refined on the exact response, or with
delays simulated on two grids with their own errors (`delayed_step`), which are kept.  A table says nothing between
its points nor outside its band, so the loop is stepped again with each table's model fitted to every
other point only: as the two grids of a delay loop (`delayed_step`), the two runs' difference is each
measure's error estimate (`measure_errors`), at least the models' largest residual on their tables as a
relative error (both models share what every table point says, e.g. a far zero that the fit adds to
mimic the plant's roll-off: 4.9e-4 at the band's top), and a measure is given to the digits it supports.  A table
whose model is refused (right-half-plane roots outside the band, a residual above 1e-3) leaves the loop
with no step response; one whose half model is refused leaves every error unknown (inf)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from engine.closed_loop.delayed_step import measure_errors
from engine.errors import EngineError
from engine.loop.fit_cache import cached_model
from engine.loop.table_model import TableModel
from engine.model.blocks import DelayTransfer, StateSpaceTransfer, TabulatedTransfer
from engine.model.network import Network

if TYPE_CHECKING:
    from engine.closed_loop.step_response import StepResponse

Stepper = Callable[[Network, float | None], "StepResponse | None"]  # network_step bound to values and a setup


def has_tables(network: Network) -> bool:
    """Whether the network is a continuous loop with tables and rational blocks or delays besides."""
    return (
        network.sample_time is None
        and network.variable == "s"
        and any(isinstance(e.transfer, TabulatedTransfer) for e in network.entries)
        and all(
            e.transfer.rational_form or isinstance(e.transfer, (TabulatedTransfer, DelayTransfer))
            for e in network.entries
        )
    )


def modelled(network: Network, every: int = 1) -> tuple[Network, list[TableModel]]:
    """The network with each table replaced by its rational model (fitted to every ``every``-th point
    above 0 rad/s), and the models; an `EngineError` where a model is refused."""
    entries, models = [], []
    for e in network.entries:
        if isinstance(e.transfer, TabulatedTransfer):
            table = e.transfer.table
            keep = np.flatnonzero(table.omega > 0)[::every]
            model = cached_model(table.omega[keep], table.response[keep], e.transfer.text)
            models.append(model)
            e = replace(e, transfer=StateSpaceTransfer(*model.realization(), source=f"model of {e.transfer.text}"))
        entries.append(e)
    return Network(network.signals, network.inputs, tuple(entries), network.variable), models


def tabulated_step(network: Network, step: Stepper, span: float | None = None) -> StepResponse | None:
    """``step`` (a network and a span -> a `StepResponse`: exact for a rational one, simulated with its
    errors for one with delays) of the loop with its tables' models, with each measure's error (at least
    the models' of every other point) and how it was obtained; None when a model is refused or the loop
    cannot be stepped."""
    try:
        full, models = modelled(network)
    except EngineError:
        return None
    found = step(full, span)
    if found is None:
        return found
    try:
        half = step(modelled(network, every=2)[0], found.t[-1])
    except EngineError:
        half = None
    worst, other = max(m.residual for m in models), None if half is None else half.measures
    errors = measure_errors(other, found.measures, 1.0)
    if found.measures is not None:  # the final value too: the DC gain is read below the tables' band
        errors["final"] = math.inf if other is None else abs(other.final - found.measures.final)
    own = found.errors or {}  # a simulation's own (the delays' grids)
    errors = {
        name: max(error, own.get(name, 0.0), worst * abs(getattr(found.measures, name) or 0.0))
        for name, error in errors.items()
    }
    fits = ", ".join(f"degree {m.degree}, residual {m.residual:.1e}" for m in models)
    how = (
        f"{'stepped exactly' if found.how is None else found.how + ';'} with each table replaced by its rational "
        f"fit ({fits}: the largest relative error on the table), each measure's error estimated by the fits of "
        "every other table point, at least that residual (relative)"
        + ("" if half is not None else " (refused or not stepped: errors unknown)")
    )
    name = found.name.replace(")", ", from the tables' rational fits)", 1)
    return replace(found, name=name, errors=errors, how=how)

"""One design's loop, formed once: a network at fixed parameter values, and that
network broken at one signal, with every form the analyses read (the blocks'
poles, the closed loop's realization; per break: the fast evaluator, the
pole-zero form, the broken network's realization and its rational part's
roots), each computed on first use and then shared.

Margins (`engine.loop.responses.loop_model`), the root locus and pole-zero
map (`engine.closed_loop.root_locus`), the closed-loop poles and their polish
(`engine.analysis`, `engine.closed_loop.poles`) all ask `design(network,
params)` for their forms, so a design's pole-zero form, realization and
blocks' poles are computed once however many of them are shown
(`tests/engine/test_design_loop.py` counts them).  A network keeps its designs
of the last few parameter values (a new value is a new design; `engine.derived`), and
a design its one realization of each loop (`closed_loop_realization` reads it too).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from engine.derived import Derived, Form
from engine.loop.evaluator import LoopEvaluator
from engine.loop.pole_zero import (
    ZpkEvaluator,
    closed_from_broken,
    loop_realization,
    realized_roots,
    without_delays,
    zpk_evaluator,
)
from engine.loop.realization import StateSpace, realize
from engine.model.blocks import block_pole_zero
from engine.model.network import Network, check_params
from engine.model.ports.state_space_ports import StateSpaceChannel

Roots = NDArray[np.complex128]


@dataclass(frozen=True)
class DesignLoop:
    """The design's network broken at ``break_at``."""

    design: Design
    break_at: str

    @functools.cached_property
    def evaluator(self) -> LoopEvaluator:
        """GH(j omega) and its slope, evaluated block by block (exact)."""
        return LoopEvaluator(self.design.network, self.break_at, self.design.params)

    @functools.cached_property
    def pole_zero(self) -> ZpkEvaluator | None:
        """The loop's pole-zero form when it matches the network (`engine.loop.pole_zero`)."""
        if not self.design.network.rational:
            return None
        return zpk_evaluator(
            self.design.network, self.break_at, self.design.params, self.evaluator, lambda: self.realization
        )

    @functools.cached_property
    def realization(self) -> StateSpace:
        """The broken network's state space (inputs: the network's, then the loop input): the one
        kept realization of the loop (the pole-zero form, the time responses and the exports read it)."""
        return loop_realization(self.design.network, self.break_at, self.design.params)

    @functools.cached_property
    def rational_roots(self) -> tuple[Roots, Roots] | None:
        """Zeros and poles of the loop's rational part (its delays unit gains: `without_delays`)
        from a realization, as accurate as its eigenvalues (near clustered light roots, a few
        digits short: the detection grid reads them as corners only); None when it has none."""
        network = self.design.network
        try:
            ss = (
                self.realization
                if network.rational
                else loop_realization(without_delays(network), self.break_at, self.design.params)
            )
            if ss.A.shape[0] == 0:
                return None
            return realized_roots(ss, network.signal(self.break_at))
        except (np.linalg.LinAlgError, ValueError):  # an EngineError is a ValueError; scipy's LinAlgError numpy's
            return None


@dataclass(frozen=True)
class Design:
    """A network at fixed parameter values (``values``: name -> value, sorted)."""

    network: Network
    values: tuple[tuple[str, float], ...]
    # its loops (one per break), its tables' fitted loops (`engine.margins.search.fitted_loop`)
    derived: Derived = field(default_factory=Derived, init=False, compare=False, repr=False)

    @functools.cached_property
    def params(self) -> dict[str, float]:
        return dict(self.values)

    def loop(self, break_at: str) -> DesignLoop:
        """The design's loop broken at ``break_at`` (one object per break)."""
        return self.derived.get(LOOP, lambda: DesignLoop(self, break_at), break_at)

    @functools.cached_property
    def block_poles(self) -> Roots:
        """Every block's own poles, from its factored form (exact to rounding) or its realization (a
        block of several ports: the eigenvalues of its A, once for all its channels)."""
        out, ported = [np.zeros(0, dtype=complex)], set()
        for e in self.network.entries:
            if isinstance(e.transfer, StateSpaceChannel):  # a block of several ports: its modes once
                if id(e.transfer.block) not in ported:
                    ported.add(id(e.transfer.block))
                    out.append(e.transfer.block.poles)
                continue
            out.append(block_pole_zero(e.transfer, self.params).poles)
        return np.concatenate([np.asarray(p, dtype=complex) for p in out])

    @functools.cached_property
    def closed_realization(self) -> StateSpace:
        """The whole network's state space (every loop closed)."""
        return realize(self.network, self.params)


LOOP: Form[DesignLoop] = Form("loop")  # a design's, asked with the signal broken
DESIGN: Form[Design] = Form("design")  # a network's, asked with its parameters' values


def design(network: Network, params: Mapping[str, float]) -> Design:
    """The design of ``network`` at ``params``: the same object while the values are the same
    (kept on the network, `engine.derived`)."""
    check_params(network, params)
    values = tuple(sorted((name, float(params[name])) for name in network.parameters))
    return network.derived.get(DESIGN, lambda: Design(network, values), values)


def seed_loop_realization(network: Network, break_at: str, params: Mapping[str, float], ss: StateSpace) -> None:
    """Hand the design's loop at ``break_at`` its broken realization made elsewhere, the matrices
    `loop_realization` makes (`engine.loop.batch_realization`: many samples' at once), so that
    its pole-zero form and closed loop read it instead of realizing the network again."""
    loop = design(network, params).loop(break_at)
    loop.__dict__.setdefault("realization", ss)


def closed_loop_realization(network: Network, break_at: str, params: Mapping[str, float]) -> StateSpace:
    """The closed loop (all loops closed) of ``network`` at ``params``, from its design's
    realization broken at ``break_at`` (`DesignLoop.realization`)."""
    return closed_from_broken(network, break_at, design(network, params).loop(break_at).realization)

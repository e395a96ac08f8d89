"""Closed-loop poles to full accuracy: the eigenvalues of the closed-loop
state matrix, polished on the network's characteristic equation.

Eigenvalues are as accurate as their conditioning allows, and digits go
where roots cluster near the origin (seen: 1e-7 to 50 % relative on
order-16 loops whose roots span 1e-3..1e2).  The characteristic polynomial
F(s) = prod_i d_i(s) det(I - G(s)) of an interconnection of blocks
b_i = n_i/d_i can be evaluated at complex s to rounding, and its roots are
refined from the eigenvalues as a gain locus's points are
(`engine.closed_loop.characteristic`, with no gain: Aberth's iteration, near-double roots
solved as units, roots stalled on the real axis restarted off it, each root
kept where |F| is smallest, so never made worse).  When a block has no
usable rational form, or the count of block poles is not the order of the
realization, the eigenvalues are kept as they are.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.characteristic import GainCharacteristic
from engine.loop.realization import Pole
from engine.model.bilinear import s_equivalent
from engine.model.network import Network


def polish(network: Network, params: Mapping[str, float], eigenvalues: NDArray[np.complex128]) -> NDArray:
    """The eigenvalues refined on F, in their order (or as given, see the module docstring)."""
    start = np.asarray(eigenvalues, dtype=complex)
    return GainCharacteristic(network, None, params).polish(1.0, start)


CONFIRMED = 1e-8  # the largest backward error of a pole shown as a root (`GainCharacteristic.backward_errors`)


def checked(
    network: Network, params: Mapping[str, float], poles: Sequence[Pole]
) -> tuple[tuple[Pole, ...], tuple[str, ...]]:
    """The poles with their backward errors against the blocks' factored forms, and a note
    naming those that are not roots to `CONFIRMED` (their digits cannot be trusted; a sampled
    loop's named in z, as it shows its poles)."""
    characteristic = GainCharacteristic(network, None, params)
    if characteristic.poles is None or not poles:
        return tuple(poles), ()
    errors = characteristic.backward_errors(np.array([p.value for p in poles], dtype=complex))
    out = tuple(replace(p, backward_error=float(e)) for p, e in zip(poles, errors))
    doubtful = [p for p in out if not p.backward_error <= CONFIRMED]
    if not doubtful:
        return out, ()
    T = network.sample_time
    named = ", ".join(
        f"{(p.value if T is None else z_pole(p, T).value):.6g} ({p.backward_error:.1g})" for p in doubtful[:3]
    )
    more = f" and {len(doubtful) - 3} more" if len(doubtful) > 3 else ""
    return out, (
        f"{len(doubtful)} closed-loop pole(s) are not roots of the characteristic equation to {CONFIRMED:g} "
        f"(backward error against the blocks' factored forms): {named}{more}; their digits are not to be trusted",
    )


def closed_loop_poles(network: Network, params: Mapping[str, float]) -> list[Pole]:
    """The closed loop's poles: the eigenvalues of its realization, polished (`polish`)."""
    from engine.loop.design import design
    from engine.loop.realization import poles

    return poles(design(network, params).closed_realization, lambda eig: polish(network, params, eig))


def closed_loop_verdict(network: Network, params: Mapping[str, float]) -> str:
    """'stable', 'unstable', 'marginally stable' (`engine.loop.realization.stability`, on
    `closed_loop_poles`; a loop with delays by `delayed_verdict`) or 'unknown' (tables, no
    realization, or a count that cannot decide)."""
    from engine.errors import EngineError
    from engine.loop.realization import stability

    if not network.rational:
        return delayed_verdict(network, params)[0]
    try:
        return stability(closed_loop_poles(network, params))
    except EngineError:
        return "unknown"


def delayed_verdict(network: Network, params: Mapping[str, float]) -> tuple[str, str]:
    """A continuous loop whose only entries without a rational form are delays: ('stable' or
    'unstable', what it rests on) by the certified argument count with the delays exact
    (`engine.multiloop.delay_stability`), or ('unknown', why not)."""
    from engine.errors import EngineError
    from engine.loop.realization import poles, realize_opened, stability
    from engine.model.blocks import DelayTransfer
    from engine.multiloop.delay_stability import delayed_verdict as counted
    from engine.multiloop.delayed import delayed_loops

    others = [e for e in network.entries if not e.transfer.rational_form and not isinstance(e.transfer, DelayTransfer)]
    if others or network.sample_time is not None:
        return "unknown", ""  # a table has no realization to count with
    try:
        opened = realize_opened(network, params)
        if not opened.taus:  # every delay 0 (a unit gain): a rational closed loop
            return stability(poles(opened.ss)), "every delay is 0: the closed loop's poles"
        system = delayed_loops(opened, (), 0.0)
    except (EngineError, np.linalg.LinAlgError) as exc:
        return "unknown", f"closed-loop stability not decided: {exc}"
    verdict = counted(system.modal, system.taus)
    return ("unknown" if verdict.status == "undecided" else verdict.status), verdict.note


def z_pole(pole: Pole, sample_time: float) -> Pole:
    """The z-plane pole z = (1 + w)/(1 - w) of a sampled loop's w-plane pole, with the damping and
    natural frequency of its s-plane equivalent s = ln(z)/T (z = 0: infinitely fast, damping 1);
    its backward error is the w-plane pole's."""
    z, damping, wn = s_equivalent(pole.value, sample_time)
    return replace(pole, value=z, damping=damping, natural_frequency=wn)

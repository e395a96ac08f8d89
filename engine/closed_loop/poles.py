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

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from engine.closed_loop.characteristic import GainCharacteristic
from engine.model.network import Network


def polish(network: Network, params: Mapping[str, float], eigenvalues: NDArray[np.complex128]) -> NDArray:
    """The eigenvalues refined on F, in their order (or as given, see the module docstring)."""
    start = np.asarray(eigenvalues, dtype=complex)
    return GainCharacteristic(network, None, params).polish(1.0, start)

"""A rational open loop in pole-zero form, for fast evaluation during margin
refinement: GH(s) = k prod(s - z_i) / prod(s - p_j) costs a few numpy
operations per batch of frequencies, however many blocks the diagram has.

A loop that is one cascade of blocks (the injection passes through each
once, as in a unity-feedback loop) takes its form from the blocks' own
factored forms (`engine.model.factored`): exact to rounding.  Any other loop takes
it from a state-space realization of the loop broken at the given signal
(poles: eigenvalues of A; zeros: the finite generalized eigenvalues of the
pencil ([[A, B], [C, D]], diag(I, 0))), with the gain matched to the exact
network at one frequency; near clustered light roots these eigenvalues can
be off in the seventh digit.  A cascade with a state-space block takes that
block's form from its own realization (`engine.model.state_space`).  Either
form is used only after it agrees with the exact evaluator
(`engine.loop.evaluator`) to 1e-9 relative at spread-out check frequencies;
otherwise the exact evaluator is kept.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from engine.derived import Derived, Form
from engine.errors import EngineError, InterconnectionError
from engine.loop.realization import StateSpace, realize
from engine.model.blocks import DelayTransfer, ExpressionTransfer, StateSpaceTransfer, block_pole_zero
from engine.model.network import Network
from engine.model.paired_product import PairedProduct

AGREEMENT = 1e-9
BATCH_ELEMENTS = 1 << 14  # root-frequency pairs per batch (256 kB of complex work array)
LOOP_INPUT = "__loop_input__"


class ZpkEvaluator:
    """GH(j omega) and dGH/domega from gain, zeros and poles (see the module docstring)."""

    def __init__(self, gain: complex, zeros: NDArray, poles: NDArray, factored: bool = False):
        self.gain = gain
        self.factored = factored  # read off the blocks' own factors: exact to rounding, no check needed
        self.product = PairedProduct(gain, zeros, poles)  # the one pole-zero kernel: zeros and poles paired
        self.zeros, self.poles = self.product.zeros, self.product.poles
        # what the grid-free searches derive from the form (`engine.margins.pole_zero.levels`), kept with it:
        # the margins and the closed-loop peaks of one loop share it
        self.derived = Derived()

    def __call__(self, omega: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        omega = np.asarray(omega, dtype=float).ravel()
        step = max(16, BATCH_ELEMENTS // max(1, self.product.roots.size))
        if omega.size <= step:
            return self._batch(omega)
        gh, dgh = np.empty(omega.size, dtype=complex), np.empty(omega.size, dtype=complex)
        for start in range(0, omega.size, step):  # a few batches that stay in cache
            part = slice(start, start + step)
            gh[part], dgh[part] = self._batch(omega[part])
        return gh, dgh

    def _batch(self, omega: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """GH and dGH/domega = j GH u at s = j omega (`engine.model.paired_product`)."""
        terms = self.product.terms(1j * omega)
        return terms.value, 1j * terms.value * terms.slope


def broken_network(network: Network, break_at: str) -> Network:
    """The network with every use of ``break_at`` fed by a new, last input instead."""
    k = network.signal(break_at)
    n = len(network.signals)
    entries = tuple(replace(e, col=n) if e.col == k else e for e in network.entries)
    return Network(
        network.signals + (LOOP_INPUT,), network.inputs + (LOOP_INPUT,), entries, network.variable, network.sample_time
    )


BROKEN: Form[Network] = Form("broken network")  # asked with the signal broken


def loop_realization(network: Network, break_at: str, params: Mapping[str, float]) -> StateSpace:
    """State space of the broken network (inputs: the network's, then the loop input); made
    each time: a design's is kept once, as `engine.loop.design.DesignLoop.realization`."""
    broken = network.derived.get(BROKEN, lambda: broken_network(network, break_at), break_at)
    return realize(broken, params)


def closed_from_broken(network: Network, break_at: str, ss: StateSpace) -> StateSpace:
    """The closed loop (all loops closed) from the broken one ``ss`` (`loop_realization`):
    u = x_break; a sampled network's realization in w keeps its sample time (it is stepped in z)."""
    k = network.signal(break_at)
    Bu, Du = ss.B[:, -1:], ss.D[:-1, -1:]
    denominator = 1.0 - ss.D[k, -1]
    if abs(denominator) < 1e-14:
        raise InterconnectionError(f"algebraic loop through {break_at!r} is singular")
    Ck, Dk = ss.C[k : k + 1] / denominator, ss.D[k : k + 1, :-1] / denominator
    C, D = ss.C[:-1], ss.D[:-1, :-1]
    return StateSpace(
        ss.A + Bu @ Ck,
        ss.B[:, :-1] + Bu @ Dk,
        C + Du @ Ck,
        D + Du @ Dk,
        network.inputs,
        network.signals,
        network.sample_time,
    )


def zpk_evaluator(
    network: Network,
    break_at: str,
    params: Mapping[str, float],
    exact,
    realization: Callable[[], StateSpace] | None = None,
) -> ZpkEvaluator | None:
    """The pole-zero form of the loop, or None when it does not match ``exact``
    (a callable giving GH and dGH/domega) closely enough: a cascade's from its
    blocks' own factored forms (exact to rounding), any other loop's from its
    realization (``realization()``: the design's; else `loop_realization`'s)."""
    chain = exact.cascade() if hasattr(exact, "cascade") else None
    if chain is not None:
        form = _cascade_form(network, chain, params)
        if form is not None:
            checks = _check_frequencies(form.zeros, form.poles)
            reference = _evaluated(exact, checks)
            if reference is not None and _matches(form, checks, reference):
                return form
    from scipy import linalg  # on first use: scipy.linalg costs a fifth of a second of start-up

    try:
        ss = realization() if realization is not None else loop_realization(network, break_at, params)
    except (EngineError, linalg.LinAlgError, ValueError):
        return None
    if ss.A.shape[0] == 0:
        return None
    try:
        zeros, poles = realized_roots(ss, network.signal(break_at))
    except (linalg.LinAlgError, ValueError):  # QZ not converging, or a realization not finite
        return None
    checks = _check_frequencies(zeros, poles)
    reference = _evaluated(exact, checks)
    if reference is None:
        return None
    shape = ZpkEvaluator(1.0, zeros, poles)(checks)[0]
    if not np.all(np.isfinite(shape)) or np.any(shape == 0):
        return None
    gain = complex(reference[0][2] / shape[2])
    if abs(gain.imag) <= 1e-9 * abs(gain):
        gain = complex(gain.real, 0.0)
    candidate = ZpkEvaluator(gain, zeros, poles)
    return candidate if _matches(candidate, checks, reference) else None


def realized_roots(ss: StateSpace, k: int) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Zeros and poles of the loop broken at signal ``k`` from the broken network's realization
    ``ss`` (`loop_realization`): the finite generalized eigenvalues of ([[A, B], [C, D]], diag(I, 0))
    short of 1e12 times the largest pole, and the eigenvalues of A.  scipy's LinAlgError or
    ValueError when QZ does not converge or the realization is not finite."""
    from scipy import linalg

    A, B, C, D = ss.A, ss.B[:, -1:], -ss.C[k : k + 1], -ss.D[k : k + 1, -1:]
    n = A.shape[0]
    pencil = np.block([[A, B], [C, D]])
    mass = np.zeros_like(pencil)
    mass[:n, :n] = np.eye(n)
    poles = linalg.eigvals(A)
    with np.errstate(all="ignore"):
        zeros = linalg.eigvals(pencil, mass)
    largest = float(np.max(np.abs(poles))) if n else 0.0
    return zeros[np.isfinite(zeros) & (np.abs(zeros) < 1e12 * max(1.0, largest))], poles


def without_delays(network: Network) -> Network:
    """The network with every delay a unit gain: the loop's rational part, whose poles and zeros
    are the loop's own when its delays lie in series with it (a delay inside an inner loop gives
    that loop infinitely many poles: these are then only the delay-free loop's)."""
    entries = tuple(
        replace(e, transfer=ExpressionTransfer("1")) if isinstance(e.transfer, DelayTransfer) else e
        for e in network.entries
    )
    return Network(network.signals, network.inputs, entries, network.variable, network.sample_time)


def _check_frequencies(zeros: NDArray, poles: NDArray) -> NDArray[np.float64]:
    """Five frequencies spread around the roots' geometric mean."""
    roots = np.abs(np.concatenate([poles, zeros]))
    roots = roots[roots > 0]
    scale = float(np.exp(np.mean(np.log(roots)))) if roots.size else 1.0
    return scale * np.array([0.0137, 0.31, 1.13, 3.7, 41.0])


def _evaluated(exact, checks: NDArray) -> tuple[NDArray, NDArray] | None:
    """``exact``'s GH and dGH/domega at the check frequencies; None when it cannot be evaluated."""
    try:
        return exact(checks)
    except EngineError:
        return None


def _matches(form: ZpkEvaluator, checks: NDArray, reference: tuple[NDArray, NDArray]) -> bool:
    """Does the form agree with the exact loop's ``reference`` (GH and its slope at
    ``checks``) to `AGREEMENT` in value and 1e-7 in slope?"""
    value, dvalue = form(checks)
    exact_value, slope = reference
    with np.errstate(all="ignore"):
        close = np.abs(value - exact_value) <= AGREEMENT * np.abs(exact_value)
        dclose = np.abs(dvalue - slope) <= 1e-7 * np.maximum(np.abs(slope), 1e-300)
    return bool(np.all(close) and np.all(dclose))


def _cascade_form(network: Network, chain: list[int], params: Mapping[str, float]) -> ZpkEvaluator | None:
    """GH = -(the chain's product) from each block's factored form (`engine.model.factored`), or a
    state-space block's form from its realization (then the form is not exact to rounding: `factored`
    is False, and the margins found on it are checked on the network)."""
    gain, zeros, poles = -1.0, [], []
    for number in chain:
        try:
            form = block_pole_zero(network.entries[number].transfer, params)
        except EngineError:
            return None
        gain *= form.gain
        zeros.append(form.zeros)
        poles.append(form.poles)
    zeros_all, poles_all = np.concatenate(zeros), np.concatenate(poles)
    if poles_all.size == 0 or not (np.all(np.isfinite(zeros_all)) and np.all(np.isfinite(poles_all))):
        return None
    factored = not any(isinstance(network.entries[number].transfer, StateSpaceTransfer) for number in chain)
    return ZpkEvaluator(complex(gain, 0.0), zeros_all, poles_all, factored=factored)

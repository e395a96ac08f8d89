"""State-space realization of a rational interconnection, closed-loop poles.

Every entry G_ij (proper, rational) is realized in controllable canonical
form (a state-space block by its own A, B, C, D; a block of several ports once, its
states shared by its channels' entries: `engine.model.ports.state_space_ports`); with D
the matrix of direct feedthroughs and C the state-to-signal map, the signal equation x = D x + C z + E u gives x = (I - D)^-1 (C z + E u),
and the states obey z' = A_blk z + B_blk x.  The result maps the exogenous
inputs to every signal, with all loops closed.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from weakref import WeakKeyDictionary

import numpy as np
from numpy.typing import NDArray

from engine.errors import BlockError, InterconnectionError
from engine.model.blocks import DelayTransfer, ExpressionTransfer, StateSpaceTransfer
from engine.model.factored import pole_zero
from engine.model.network import Network
from engine.model.ports.state_space_ports import StateSpaceChannel
from engine.numerics.polynomials import degree, trim


@dataclass(frozen=True)
class StateSpace:
    """x' = A x + B u, y = C x + D u; ``outputs`` are signal names, ``inputs`` exogenous."""

    A: NDArray[np.float64]
    B: NDArray[np.float64]
    C: NDArray[np.float64]
    D: NDArray[np.float64]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    sample_time: float | None = None  # a sampled loop's realization in w (`Network.sampled`)


@dataclass(frozen=True)
class Pole:
    """A closed-loop pole with its damping ratio and natural frequency (rad/s)."""

    value: complex
    damping: float
    natural_frequency: float
    backward_error: float | None = None  # as a root of the blocks' characteristic equation (None: not checked)

    @property
    def zeta(self) -> float:
        """The damping ratio -Re p/|p| (1 at the origin, negative in the right half-plane)."""
        return self.damping

    @property
    def wn(self) -> float:
        """The natural frequency |p| (rad/s)."""
        return self.natural_frequency


def realize(network: Network, params: Mapping[str, float]) -> StateSpace:
    """Closed-loop state space from the network's inputs to all its signals."""
    if not network.rational:
        kinds = sorted({type(e.transfer).__name__ for e in network.entries if not e.transfer.rational_form})
        raise InterconnectionError(f"no state-space realization: the network has {', '.join(kinds)} entries")
    return _closed(network, params, {})


@dataclass(frozen=True)
class OpenedDelays:
    """A continuous loop with time delays, each delay opened: ``ss`` realizes the rational rest, its inputs
    the network's followed by one per delay (the delay's output, added to the signal it feeds), its outputs
    every signal (among them each delay's input).  Delay k: ``taus[k]`` seconds from signal
    ``ss.outputs[delay_outputs[k]]`` to input ``ss.inputs[delay_inputs[k]]``."""

    ss: StateSpace
    taus: tuple[float, ...]
    delay_inputs: tuple[int, ...]
    delay_outputs: tuple[int, ...]


def realize_opened(network: Network, params: Mapping[str, float]) -> OpenedDelays:
    """The loop with its delays exp(-tau s) opened (`OpenedDelays`); a delay of 0 is a unit gain.  An
    `InterconnectionError` for a sampled network or any other entry that is not rational (a table)."""
    if network.sample_time is not None or network.variable != "s":
        raise InterconnectionError("delays are opened in a continuous loop (in s) only")
    others = sorted(
        {
            type(e.transfer).__name__
            for e in network.entries
            if not e.transfer.rational_form and not isinstance(e.transfer, DelayTransfer)
        }
    )
    if others:
        raise InterconnectionError(f"no state-space realization: the network has {', '.join(others)} entries")
    opened: dict[int, float] = {}
    for number, entry in enumerate(network.entries):
        if isinstance(entry.transfer, DelayTransfer):
            tau = entry.transfer.tau
            value = float(params[tau]) if isinstance(tau, str) else float(tau)
            if not (np.isfinite(value) and value >= 0):
                raise BlockError(f"{entry.label}: a delay must be finite and >= 0, not {value!r}")
            opened[number] = value
    ss = _closed(network, params, opened)
    cut = [k for k, tau in opened.items() if tau > 0]
    first = len(network.inputs)
    return OpenedDelays(
        ss,
        tuple(opened[k] for k in cut),
        tuple(first + i for i in range(len(cut))),
        tuple(network.entries[k].col for k in cut),
    )


def _closed(network: Network, params: Mapping[str, float], opened: Mapping[int, float]) -> StateSpace:
    """`realize`'s state space; the entries ``opened`` (number -> delay) are delays: one of 0 a unit
    gain, each other left out, its output an extra input (after the network's) at the signal it feeds."""
    n = len(network.signals)
    units: list[_Unit] = []
    ported: dict[int, _Unit] = {}  # a block of several ports (id of it): its states once, every channel's wires
    feed = np.zeros((n, n))
    cut = [k for k, tau in opened.items() if tau > 0]
    for number, entry in enumerate(network.entries):
        if number in opened:
            feed[entry.row, entry.col] += 0.0 if opened[number] > 0 else 1.0
            continue
        t = entry.transfer
        if isinstance(t, StateSpaceChannel):
            if id(t.block) not in ported:
                ported[id(t.block)] = _Unit(t.block.A, {}, {})
                units.append(ported[id(t.block)])
            unit = ported[id(t.block)]
            unit.reads[(t.input_port, entry.col)] = t.block.B[:, t.input_port]
            unit.writes[(t.output_port, entry.row)] = t.block.C[t.output_port]
            feed[entry.row, entry.col] += t.block.D[t.output_port, t.input_port]
            continue
        a, b, c, d = entry_realization(network, number, params)
        units.append(_Unit(a, {(0, entry.col): b[:, 0]}, {(0, entry.row): c[0, :]}))
        feed[entry.row, entry.col] += d[0, 0] if d.size else 0.0
    m = sum(unit.a.shape[0] for unit in units)
    A_blk, B_blk, C_sig = np.zeros((m, m)), np.zeros((m, n)), np.zeros((n, m))
    offset = 0
    for unit in units:
        sl = slice(offset, offset + unit.a.shape[0])
        A_blk[sl, sl] = unit.a
        for (_, col), b in unit.reads.items():
            B_blk[sl, col] += b
        for (_, row), c in unit.writes.items():
            C_sig[row, sl] += c
        offset += unit.a.shape[0]
    E = np.zeros((n, len(network.inputs) + len(cut)))
    for k, name in enumerate(network.inputs):
        E[network.signal(name), k] = 1.0
    for i, number in enumerate(cut):
        E[network.entries[number].row, len(network.inputs) + i] = 1.0
    inputs = network.inputs + tuple(f"{network.entries[k].label} (delay opened)" for k in cut)
    lu = factored_feedthrough(np.eye(n) - feed)
    from scipy import linalg  # on first use (start-up)

    P_state, P_input = linalg.lu_solve(lu, C_sig, check_finite=False), linalg.lu_solve(lu, E, check_finite=False)
    A = A_blk + B_blk @ P_state
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(P_state)) and np.all(np.isfinite(P_input))):
        raise InterconnectionError("the closed loop's realization leaves the floating-point range")
    return StateSpace(A, B_blk @ P_input, P_state, P_input, inputs, network.signals, network.sample_time)


@dataclass(frozen=True)
class _Unit:
    """The states of one block in a network's realization: its A, and its input columns and output
    rows by (port, signal) (a SISO block: one of each; a block of several ports: one per port)."""

    a: NDArray[np.float64]
    reads: dict[tuple[int, int], NDArray[np.float64]]
    writes: dict[tuple[int, int], NDArray[np.float64]]


def factored_feedthrough(matrix: NDArray) -> tuple:
    """LU factors of I - D, or a clear error when it is singular.  A pivot
    is zero when it is rounding noise against the terms it was computed
    from (diag(|L| |U|)): the test is blind to scaling, so a chain of gains
    from 3e-20 to 1e11 around a loop with 1 + GH(inf) = 8.77 is not
    mistaken for a singular one, while a loop gain of exactly -1 is."""
    from scipy import linalg  # on first use: scipy.linalg costs a fifth of a second of start-up

    if not np.all(np.isfinite(matrix)):
        raise InterconnectionError("a direct feedthrough is not finite")
    with warnings.catch_warnings():  # an exactly zero pivot is the error below, not a warning
        warnings.simplefilter("ignore", linalg.LinAlgWarning)
        lu = linalg.lu_factor(matrix, check_finite=False)
    lower, upper = np.tril(lu[0], -1) + np.eye(matrix.shape[0]), np.triu(lu[0])
    terms = np.diag(np.abs(lower) @ np.abs(upper))
    if np.any(np.abs(np.diag(upper)) <= 1e-12 * terms):
        raise InterconnectionError("algebraic loop is singular: I - D (direct feedthrough) has no inverse")
    return lu


def _without_one(r):
    """``r`` without the factors (1 - w) its numerator and denominator share (both 0 at w = 1 to
    rounding), divided out: a loop in z written with z = (1 + w)/(1 - w) leaves them, and they
    must cancel, not be a pole at w = 1 (z = inf); every other root, a pole a zero cancels
    included, stays, as in s."""

    def vanishes(p: NDArray) -> bool:
        return p.size > 1 and abs(np.polyval(p, 1.0)) <= 1e-12 * max(np.sum(np.abs(p)), 1e-300)

    num, den = trim(r.num), trim(r.den)
    while vanishes(num) and vanishes(den):
        num, den = np.polydiv(num, [1.0, -1.0])[0], np.polydiv(den, [1.0, -1.0])[0]
    return replace(r, num=num, den=den)


_REALIZED: WeakKeyDictionary = WeakKeyDictionary()  # transfer without parameters -> its (A, B, C, D)


def entry_realization(network: Network, number: int, params: Mapping[str, float]) -> tuple[NDArray, ...]:
    """One entry's (A, B, C, D); kept on its transfer when that has no parameters
    (a network and its broken copy, `engine.loop.pole_zero`, share it)."""
    entry = network.entries[number]
    fixed = not entry.transfer.parameters
    if fixed and entry.transfer in _REALIZED:
        return _REALIZED[entry.transfer]
    expression = entry.transfer.expression if isinstance(entry.transfer, ExpressionTransfer) else None
    folded = expression.folded(params) if expression is not None else None
    if folded is not None and network.variable == "w":
        folded = _without_one(folded)
    if isinstance(entry.transfer, StateSpaceTransfer):
        realization = entry.transfer.realization()  # as given: no roots, no polynomials
    elif folded is not None and degree(folded.num) <= degree(folded.den) and degree(folded.den) >= 0:
        realization = cascade(trim(folded.num), trim(folded.den))  # a small ratio: no roots needed
    elif expression is not None:
        form = pole_zero(expression, params)  # factor by factor: no expansion loses the roots' digits
        if form.zeros.size > form.poles.size:
            entry.transfer.check_proper(params, entry.label)  # names the degrees
            raise BlockError(f"{entry.label}: improper transfer function")
        realization = cascade_roots(form.gain, form.zeros, form.poles)
    else:
        r = entry.transfer.check_proper(params, entry.label)
        realization = cascade(r.num, r.den)
    if not all(np.all(np.isfinite(m)) for m in realization):
        raise BlockError(f"{entry.label}: its realization's numbers leave the floating-point range")
    if fixed:
        _REALIZED[entry.transfer] = realization
    return realization


def _sections(roots: NDArray[np.complex128]) -> list[NDArray[np.float64]]:
    """Real polynomials of degree 1 or 2 whose product has the given roots."""
    roots = np.asarray(roots, dtype=complex)
    upper = sorted((r for r in roots if r.imag > 1e-12 * max(1.0, abs(r))), key=abs)
    reals = sorted((r.real for r in roots if abs(r.imag) <= 1e-12 * max(1.0, abs(r))), key=abs)
    out = [np.array([1.0, -2.0 * r.real, abs(r) ** 2]) for r in upper]
    out += [np.poly(reals[i : i + 2]).real for i in range(0, len(reals), 2)]
    return out


def cascade(num: NDArray, den: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """A well-scaled realization of num/den (proper): a series of first- and
    second-order sections built from its roots (high-order companion forms lose
    digits).  Sections sorted by degree pair up properly because each
    polynomial has at most one first-order section."""
    if den.size == 1:
        if num.size > 1:
            raise BlockError("improper transfer function in cascade realization")
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[num[0] / den[0]]])
    if den.size <= 3 and num.size <= den.size:
        return _section(num, den)  # one section already: no roots needed
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        raise BlockError(f"polynomial coefficients overflow (degree {den.size - 1})")
    return cascade_roots(
        num[0] / den[0], np.roots(num) if num.size > 1 else np.zeros(0), np.roots(den) if den.size > 1 else np.zeros(0)
    )


def cascade_roots(gain: float, zero_roots: NDArray, pole_roots: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """`cascade` of gain * prod(s - zeros)/prod(s - poles), from the roots."""
    zeros = sorted(_sections(zero_roots), key=len, reverse=True)
    poles = sorted(_sections(pole_roots), key=len, reverse=True)
    if not poles:
        if zeros:
            raise BlockError("improper transfer function in cascade realization")
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.array([[gain]])
    if len(zeros) > len(poles):
        raise BlockError("improper transfer function in cascade realization")
    sections = [_section(zeros[k] if k < len(zeros) else np.ones(1), p) for k, p in enumerate(poles)]
    size = sum(a.shape[0] for a, _, _, _ in sections)
    A, B, C, D = np.zeros((size, size)), np.zeros((size, 1)), np.zeros((1, size)), np.array([[gain]])
    top = 0  # the series so far has states :top; each section feeds on its output C x + D u
    for a, b, c, d in sections:
        n = a.shape[0]
        A[top : top + n, :top], A[top : top + n, top : top + n] = b @ C[:, :top], a
        B[top : top + n] = b @ D
        C[:, :top], C[:, top : top + n] = d @ C[:, :top], c
        D = d @ D
        top += n
    return A, B, C, D


def _section(num: NDArray, den: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Controllable canonical form of num/den (descending, deg num <= deg den <= 2),
    as scipy.signal.tf2ss writes it, without its general-purpose overhead."""
    a = den / den[0]
    b = np.concatenate([np.zeros(den.size - num.size), num]) / den[0]
    n = den.size - 1
    A = np.zeros((n, n))
    A[0] = -a[1:]
    A[np.arange(1, n), np.arange(n - 1)] = 1.0
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    return A, B, (b[1:] - b[0] * a[1:])[None, :], np.array([[b[0]]])


def poles(ss: StateSpace, refine: Callable[[NDArray], NDArray] | None = None) -> list[Pole]:
    """Eigenvalues of the closed-loop A, sorted by real part (least stable
    last); ``refine`` polishes them (`engine.closed_loop.poles`)."""
    eig = np.linalg.eigvals(ss.A) if ss.A.size else np.zeros(0, dtype=complex)
    if refine is not None and eig.size:
        eig = refine(eig)
    eig = sorted(eig, key=lambda p: (p.real, p.imag))
    out = []
    for p in eig:
        wn = abs(p)
        out.append(Pole(complex(p), float(-p.real / wn) if wn > 0 else 1.0, float(wn)))
    return out


AXIS = 1e-12  # |Re p| within this of |p| (|zeta| <= 1e-12): a pole on the imaginary axis
ORIGIN = 1e-12  # |p| within this of the largest pole's modulus: a pole at the origin


def stability(pole_list: list[Pole]) -> str:
    """'unstable' (a pole right of the axis), 'marginally stable' (none, and one on it by
    `marginal_poles`' rule) or 'stable'."""
    values = np.array([p.value for p in pole_list], dtype=complex)
    if unstable_rows(values[None, :])[0]:
        return "unstable"
    return "marginally stable" if on_the_axis(values).any() else "stable"


def marginal_poles(pole_list: list[Pole]) -> list[Pole]:
    """The poles taken to lie on the imaginary axis (`on_the_axis`)."""
    on_axis = on_the_axis(np.array([p.value for p in pole_list], dtype=complex))
    return [p for p, there in zip(pole_list, on_axis.tolist()) if there]


def on_the_axis(poles: NDArray[np.complex128]) -> NDArray[np.bool_]:
    """Which poles (the last axis: one loop's; a leading axis of samples allowed) lie on the
    imaginary axis: |zeta| <= AXIS (relative to the pole's own modulus), or |p| <= ORIGIN times
    the largest pole's modulus (at the origin relative to the loop's fastest pole).  A real pole
    at -2.8e-11 beside poles of modulus 3 is stable (a time constant of 3.6e10 s: slow, not
    marginal)."""
    size = np.abs(poles)
    scale = np.max(size, axis=-1, initial=0.0, keepdims=True)
    return (np.abs(poles.real) <= AXIS * size) | (size <= ORIGIN * scale)


def unstable_rows(poles: NDArray[np.complex128]) -> NDArray[np.bool_]:
    """Per row of poles (one loop's each): is a pole right of the axis that `on_the_axis` does not put on it?"""
    return ((poles.real > 0) & ~on_the_axis(poles)).any(axis=-1)


def stability_note(pole_list: list[Pole]) -> str | None:
    """What a 'marginally stable' verdict rests on (None for any other)."""
    if stability(pole_list) != "marginally stable":
        return None
    on_axis = marginal_poles(pole_list)
    named = ", ".join(f"{p.value:.6g}" for p in on_axis[:4]) + (
        f" and {len(on_axis) - 4} more" if len(on_axis) > 4 else ""
    )
    scale = max(abs(p.value) for p in pole_list)
    return (
        f"marginally stable: {len(on_axis)} pole(s) on the imaginary axis ({named}): |Re p| <= {AXIS:g} |p|, "
        f"or |p| <= {ORIGIN:g} of the largest pole's modulus ({scale:.6g}); every other pole has Re p < 0"
    )

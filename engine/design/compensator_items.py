"""A compensator as the engineer reads it: its gain (the Bode gain, with every factor
written as (1 + s/w)), its real zeros and poles as corner frequencies and time
constants, its complex pairs as (wn, zeta), its integrators and differentiators, and
for each the parameters that move it (found by nudging each parameter: a root that
moves belongs to it).  Moving an item is `compensator_moves`."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from engine.errors import EngineError
from engine.model.bilinear import s_equivalent
from engine.model.blocks import ExpressionTransfer
from engine.model.factor_text import root_factors, time_constant_factor
from engine.model.factored import pole_zero
from engine.model.network import Network
from engine.model.paired_product import PairedProduct

NUDGE = 1e-6  # relative change of a parameter that tells which roots it moves
MOVED = 1e-9  # relative change of a root (or the gain) that counts as moved
ORIGIN = 1e-12  # a root this small beside the largest is at the origin


@dataclass(frozen=True)
class Item:
    """One part of a compensator: ``kind`` is gain, zero, pole, zero pair, pole pair,
    integrator or differentiator; ``root`` the (upper) root (the gain's value for the
    gain); ``parameters`` the names that move it."""

    kind: str
    root: complex
    parameters: tuple[str, ...]

    @property
    def text(self) -> str:
        """'zero at 1 rad/s (T 1 s) [T1]', 'pole pair wn 2 rad/s zeta 0.3 [a, b]', 'gain 7.1 (17.1 dB) [K]'."""
        return self.reading()

    def reading(self, sample_time: float | None = None) -> str:
        """`text`; of a sampled loop's compensator (its roots found in w), the root in z with its
        s-plane equivalent: 'zero at z = 0.92 (0.167 rad/s) [T1]', 'pole pair at z = 0.5+-0.8j
        (wn 2.04 rad/s zeta 0.036) [a, b]'."""
        by = f" [{', '.join(self.parameters)}]" if self.parameters else " [fixed]"
        if sample_time is not None and self.kind not in ("gain", "integrator", "differentiator"):
            z, damping, wn = s_equivalent(self.root, sample_time)
            if not math.isfinite(wn):
                return f"{self.kind} at z = {z.real:.6g}{by}"
            at = f"{z.real:.6g}" + (f"+-{abs(z.imag):.6g}j" if z.imag else "")
            if self.kind.endswith("pair"):
                return f"{self.kind} at z = {at} (wn {wn:.6g} rad/s zeta {damping:.4g}){by}"
            return f"{self.kind} at z = {at} ({wn:.6g} rad/s){by}"
        if self.kind == "gain":
            value = self.root.real
            db = f" ({round(20 * math.log10(abs(value)), 9) + 0.0:.4g} dB)" if value else ""  # + 0.0: never "-0 dB"
            return f"gain {value:.6g}{db}{by}"
        if self.kind in ("integrator", "differentiator"):
            return f"{self.kind}{by}"
        w = abs(self.root)
        if self.kind.endswith("pair"):
            return f"{self.kind} wn {w:.6g} rad/s zeta {-self.root.real / w:.4g}{by}"
        side = "" if self.root.real <= 0 else " (right half-plane)"
        return f"{self.kind} at {w:.6g} rad/s (T {1 / w:.6g} s){side}{by}"


def items(transfer: ExpressionTransfer, params: Mapping[str, float]) -> list[Item]:
    """The gain, then the zeros and poles of a block, low frequency first.  Kept for the
    latest designs (`ITEMS_KEPT`, by the block itself and its parameters' values): a nudge
    reads its block's items where the shaping table read them after the nudge before."""
    return list(_items_at(_Same(transfer), tuple((name, params[name]) for name in transfer.parameters)))


ITEMS_KEPT = 16  # the (block, values) whose items are kept (`items`)


class _Same:
    """A block as a key: equal to the same object alone (a block is never changed in place)."""

    def __init__(self, transfer: ExpressionTransfer) -> None:
        self.transfer = transfer

    def __hash__(self) -> int:
        return id(self.transfer)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Same) and other.transfer is self.transfer


@lru_cache(maxsize=ITEMS_KEPT)
def _items_at(block: _Same, values: tuple[tuple[str, float], ...]) -> tuple[Item, ...]:
    """`items` of a block at its parameters' values (the key holds the block: its id stays its own)."""
    transfer, params = block.transfer, dict(values)
    base = pole_zero(transfer.expression, params)
    scale = _scale(base)
    gain = _bode_gain(base, scale)
    moved = {name: _moved(transfer, params, name, base, scale, gain) for name in transfer.parameters}
    return tuple(
        _listed(base, lambda index, k: tuple(n for n, m in moved.items() if (m[0] if index == 0 else m[index][k])))
    )


def readings(transfer: ExpressionTransfer, params: Mapping[str, float]) -> list[Item]:
    """The items of `items` without the parameters that move them (one pole-zero form)."""
    return _listed(pole_zero(transfer.expression, params), lambda index, k: ())


def _listed(base, by: Callable[[int, int], tuple[str, ...]]) -> list[Item]:
    """The items of a pole-zero form; ``by(0, 0)`` names the gain's parameters, ``by(1, k)``
    zero k's, ``by(2, k)`` pole k's."""
    scale = _scale(base)
    out = [Item("gain", complex(_bode_gain(base, scale)), by(0, 0))]
    found = []
    for kind, roots, index in (("zero", base.zeros, 1), ("pole", base.poles, 2)):
        for k, r in enumerate(roots):
            if r.imag < 0:
                continue  # a pair is listed once, by its upper root
            if abs(r) <= ORIGIN * scale:
                found.append((0.0, Item("differentiator" if kind == "zero" else "integrator", 0j, by(index, k))))
            else:
                found.append((abs(r), Item(f"{kind} pair" if r.imag > 0 else kind, complex(r), by(index, k))))
    return out + [item for _, item in sorted(found, key=lambda pair: pair[0])]


def compensators(network: Network, params: Mapping[str, float]) -> dict[str, list[Item]]:
    """The items of every compensator of a loop (its entries with parameters), by label."""
    return {
        e.label: items(e.transfer, params)
        for e in network.entries
        if isinstance(e.transfer, ExpressionTransfer) and e.transfer.parameters
    }


def named(found: list[Item]) -> list[str]:
    """The items' names, as `loopcraft set` takes them: gain, zero1, pole2, zeropair1,
    polepair1, integrator1, differentiator1 (numbered by kind, low frequency first)."""
    counts: dict[str, int] = {}
    out = []
    for item in found:
        kind = item.kind.replace(" ", "")
        if kind == "gain":
            out.append("gain")
            continue
        counts[kind] = counts.get(kind, 0) + 1
        out.append(f"{kind}{counts[kind]}")
    return out


def _scale(base) -> float:
    """The largest root's size (1 without roots): what counts as the origin beside it (`ORIGIN`)."""
    return max([abs(r) for r in [*base.zeros, *base.poles]], default=1.0) or 1.0


def _bode_gain(base, scale: float) -> float:
    """The gain with each factor away from the origin written (1 + s/w): gain * prod(-z)/prod(-p)."""
    zeros = [z for z in base.zeros if abs(z) > ORIGIN * scale]
    poles = [p for p in base.poles if abs(p) > ORIGIN * scale]
    return float(PairedProduct(base.gain, np.asarray(zeros), np.asarray(poles)).terms(np.zeros(1)).value[0].real)


def _moved(
    transfer: ExpressionTransfer, params: Mapping[str, float], name: str, base, scale: float, gain: float
) -> tuple:
    """Does nudging ``name`` move the Bode ``gain``, and which zeros and poles (by index)?"""
    value = params[name]
    nudged = {**params, name: value * (1 + NUDGE) if value else NUDGE}
    try:
        other = pole_zero(transfer.expression, nudged)
    except EngineError:
        return False, [False] * base.zeros.size, [False] * base.poles.size
    if other.zeros.size != base.zeros.size or other.poles.size != base.poles.size:
        return True, [True] * base.zeros.size, [True] * base.poles.size  # the structure changed
    moves_gain = abs(_bode_gain(other, scale) / gain - 1) > MOVED if gain else True
    return moves_gain, _which(base.zeros, other.zeros, scale), _which(base.poles, other.poles, scale)


def _which(before: np.ndarray, after: np.ndarray, scale: float) -> list[bool]:
    """Which roots moved: each matched to the nearest root after the nudge."""
    left = list(after)
    out = []
    for r in before:
        if not left:
            out.append(True)
            continue
        k = int(np.argmin([abs(a - r) for a in left]))
        out.append(abs(left.pop(k) - r) > MOVED * max(abs(r), ORIGIN * scale))
    return out


def measure(item: Item, kind: str = "frequency") -> float:
    """What a move of an item changes: its frequency (rad/s), a pair's damping (``kind=
    "damping"``), the gain's size (its magnitude: a move keeps its sign)."""
    if item.kind == "gain":
        return abs(item.root.real)
    if kind == "damping":
        return max(-item.root.real / abs(item.root), 1e-300)
    return abs(item.root)


def time_constant_form(found: list[Item], variable: str = "s") -> str:
    """The compensator in time-constant form, from its items: '7.14 (1 + s/0.667) /
    (1 + s/10)', a pair '(1 + 2*0.3*s/2 + (s/2)^2)', an integrator '/s'."""
    s = variable
    over, under = [], []
    for item in found[1:]:
        factor = time_constant_factor(item.root, s, item.kind.endswith("pair"))
        (over if item.kind.startswith(("zero", "differentiator")) else under).append(factor)
    text = " ".join([f"{found[0].root.real:.6g}", *over])
    return text + (f" / ({' '.join(under)})" if len(under) > 1 else f" / {under[0]}" if under else "")


def pole_zero_form(transfer: ExpressionTransfer, params: Mapping[str, float]) -> str:
    """The compensator in gain/zero/pole form: '71.4 (s + 0.667) / (s + 10)', a pair as
    '(s^2 + 1.2 s + 4)'."""
    base = pole_zero(transfer.expression, params)
    s = transfer.expression.variable

    over = root_factors(sorted(base.zeros, key=abs), s, exact=False)
    under = root_factors(sorted(base.poles, key=abs), s, exact=False)
    text = " ".join([f"{base.gain.real:.6g}", *over])
    return text + (f" / ({' '.join(under)})" if len(under) > 1 else f" / {under[0]}" if under else "")

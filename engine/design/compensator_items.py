"""A compensator as the engineer reads it: its gain (the Bode gain, with every factor
written as (1 + s/w)), its real zeros and poles as corner frequencies and time
constants, its complex pairs as (wn, zeta), its integrators and differentiators, and
for each the parameters that move it (found by nudging each parameter: a root that
moves belongs to it)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from engine.errors import EngineError
from engine.model.blocks import ExpressionTransfer
from engine.model.factored import pole_zero
from engine.model.network import Network

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
        by = f" [{', '.join(self.parameters)}]" if self.parameters else " [fixed]"
        if self.kind == "gain":
            value = self.root.real
            db = f" ({round(20 * math.log10(abs(value)), 9):.4g} dB)" if value else ""
            return f"gain {value:.6g}{db}{by}"
        if self.kind in ("integrator", "differentiator"):
            return f"{self.kind}{by}"
        w = abs(self.root)
        if self.kind.endswith("pair"):
            return f"{self.kind} wn {w:.6g} rad/s zeta {-self.root.real / w:.4g}{by}"
        side = "" if self.root.real <= 0 else " (right half-plane)"
        return f"{self.kind} at {w:.6g} rad/s (T {1 / w:.6g} s){side}{by}"


def items(transfer: ExpressionTransfer, params: Mapping[str, float]) -> list[Item]:
    """The gain, then the zeros and poles of a block, low frequency first."""
    base = pole_zero(transfer.expression, params)
    moved = {name: _moved(transfer, params, name, base) for name in transfer.parameters}
    scale = max([abs(r) for r in [*base.zeros, *base.poles]], default=1.0) or 1.0
    out = [Item("gain", complex(_bode_gain(base, scale)), tuple(n for n, m in moved.items() if m[0]))]
    found = []
    for kind, roots, index in (("zero", base.zeros, 1), ("pole", base.poles, 2)):
        for k, r in enumerate(roots):
            if r.imag < 0:
                continue  # a pair is listed once, by its upper root
            by = tuple(n for n, m in moved.items() if m[index][k])
            if abs(r) <= ORIGIN * scale:
                found.append((0.0, Item("differentiator" if kind == "zero" else "integrator", 0j, by)))
            else:
                found.append((abs(r), Item(f"{kind} pair" if r.imag > 0 else kind, complex(r), by)))
    return out + [item for _, item in sorted(found, key=lambda pair: pair[0])]


def compensators(network: Network, params: Mapping[str, float]) -> dict[str, list[Item]]:
    """The items of every compensator of a loop (its entries with parameters), by label."""
    return {
        e.label: items(e.transfer, params)
        for e in network.entries
        if isinstance(e.transfer, ExpressionTransfer) and e.transfer.parameters
    }


@dataclass(frozen=True)
class Move:
    """An item moved by name: the parameter solved for and its value, the item's measure
    before (``now``) and asked (``target``)."""

    parameter: str
    value: float
    now: float
    target: float


def move_named(
    network: Network,
    params: Mapping[str, float],
    name: str,
    target: Callable[[float], float],
    bounds: Mapping[str, tuple[float | None, float | None]] | None = None,
) -> Move:
    """Move the item ``BLOCK.ITEM`` (its frequency, or the gain) or ``BLOCK.ITEM.zeta`` (a
    pair's damping) of a loop, items named as `named`, to ``target(now)`` (`moved`)."""
    block, _, rest = name.partition(".")
    item_name, _, suffix = rest.partition(".")
    entry = next((e for e in network.entries if e.label == block), None)
    if entry is None or not isinstance(entry.transfer, ExpressionTransfer) or not entry.transfer.parameters:
        raise EngineError(f"{name}: no compensator block {block!r} (loopcraft analyze FILE lists them)")
    found = items(entry.transfer, params)
    names = named(found)
    if item_name not in names or suffix not in ("", "zeta"):
        raise EngineError(f"{name}: {block} has {', '.join(names)} (and ITEM.zeta for a pair's damping)")
    index = names.index(item_name)
    kind = "damping" if suffix else "frequency"
    now = measure(found[index], kind)
    wanted = target(now)
    try:
        parameter, value = moved(entry.transfer, params, index, wanted, kind, bounds)
    except EngineError as exc:
        raise EngineError(f"{name}: {exc}") from None
    return Move(parameter, value, now, wanted)


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


def _bode_gain(base, scale: float) -> float:
    """The gain with each factor away from the origin written (1 + s/w): gain * prod(-z)/prod(-p)."""
    zeros = [z for z in base.zeros if abs(z) > ORIGIN * scale]
    poles = [p for p in base.poles if abs(p) > ORIGIN * scale]
    return float((base.gain * np.prod(-np.asarray(zeros)) / np.prod(-np.asarray(poles))).real)


def _moved(transfer: ExpressionTransfer, params: Mapping[str, float], name: str, base) -> tuple:
    """Does nudging ``name`` move the gain, and which zeros and poles (by index)?"""
    value = params[name]
    nudged = {**params, name: value * (1 + NUDGE) if value else NUDGE}
    try:
        other = pole_zero(transfer.expression, nudged)
    except EngineError:
        return False, [False] * base.zeros.size, [False] * base.poles.size
    if other.zeros.size != base.zeros.size or other.poles.size != base.poles.size:
        return True, [True] * base.zeros.size, [True] * base.poles.size  # the structure changed
    scale = max([abs(r) for r in [*base.zeros, *base.poles]], default=1.0) or 1.0
    gain = abs(_bode_gain(other, scale) / _bode_gain(base, scale) - 1) > MOVED if _bode_gain(base, scale) else True
    return gain, _which(base.zeros, other.zeros, scale), _which(base.poles, other.poles, scale)


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


GROWTH = 2.0  # the bracket around a parameter's value grows by this factor a step
BRACKET_STEPS = 40  # at most 2^40 either way
TOLERANCE = 1e-12  # relative, on the solved parameter


def moved(
    transfer: ExpressionTransfer,
    params: Mapping[str, float],
    index: int,
    target: float,
    kind: str = "frequency",
    bounds: Mapping[str, tuple[float | None, float | None]] | None = None,
) -> tuple[str, float]:
    """The parameter and its value that bring item ``index`` (of `items`) to ``target``:
    the frequency of a zero, pole or pair, the damping of a pair (``kind="damping"``),
    the value of the gain.  One parameter is solved for, the one that moves this item's
    measure most and the other items least; within its ``bounds``.  An `EngineError` says
    why it cannot (a fixed item, a target out of the parameter's reach)."""
    item = items(transfer, params)[index]
    if not item.parameters:
        raise EngineError(f"the {item.kind} is fixed: no parameter moves it")
    name = _mover(transfer, params, index, kind)
    value = params[name]
    if not value or not math.isfinite(value):
        raise EngineError(f"{name} is {value!r}: a value of 0 cannot be scaled to move the {item.kind}")
    low, high = (bounds or {}).get(name, (None, None))

    def miss(log_scale: float) -> float:
        found = _tracked(transfer, {**params, name: value * math.exp(log_scale)}, item)
        return math.log(measure(found, kind)) - math.log(target)

    here = miss(0.0)
    if here == 0:
        return name, value
    for side in (1.0, -1.0):
        step = 0.0
        for _ in range(BRACKET_STEPS):
            step += side * math.log(GROWTH)
            scaled = value * math.exp(step)
            if (low is not None and scaled < low) or (high is not None and scaled > high):
                break
            try:
                there = miss(step)
            except EngineError:
                break
            if np.sign(there) != np.sign(here):
                root = brentq(miss, min(0.0, step), max(0.0, step), xtol=TOLERANCE)
                return name, value * math.exp(root)
    raise EngineError(f"no value of {name} within its bounds brings the {item.kind}'s {kind} to {target:.6g}")


def measure(item: Item, kind: str = "frequency") -> float:
    """What a move of an item changes: its frequency (rad/s), a pair's damping (``kind=
    "damping"``), the gain's size (its magnitude: a move keeps its sign)."""
    if item.kind == "gain":
        return abs(item.root.real)
    if kind == "damping":
        return max(-item.root.real / abs(item.root), 1e-300)
    return abs(item.root)


def _tracked(transfer: ExpressionTransfer, params: Mapping[str, float], like: Item) -> Item:
    """The item of the same kind nearest ``like`` (in log frequency) at other values."""
    same = [i for i in items(transfer, params) if i.kind == like.kind]
    if not same:
        raise EngineError(f"the {like.kind} is gone at these values")
    if like.kind == "gain":
        return same[0]
    return min(same, key=lambda i: abs(math.log(abs(i.root) or 1e-300) - math.log(abs(like.root) or 1e-300)))


def _mover(transfer: ExpressionTransfer, params: Mapping[str, float], index: int, kind: str) -> str:
    """Of the parameters that move item ``index``, the one that moves its measure most
    relative to how much it moves the others."""
    base = items(transfer, params)
    item = base[index]
    shared = {n for i in base if i is not item and i.kind != "gain" for n in i.parameters}
    own = [n for n in item.parameters if n not in shared]
    if not own and item.kind == "gain":
        raise EngineError("no one parameter sets the gain alone: write the compensator as K*(...) with a gain K")
    if not own:
        raise EngineError(
            f"the {item.kind} is set by {', '.join(item.parameters)} together with other roots (a polynomial's "
            "coefficients): no one parameter moves it alone"
        )
    best, score = own[0], -math.inf
    for name in own:
        value = params[name]
        nudged = {**params, name: value * (1 + NUDGE) if value else NUDGE}
        try:
            after = items(transfer, nudged)
            own = abs(math.log(measure(_tracked(transfer, nudged, item), kind) / measure(item, kind)))
        except (EngineError, ValueError):
            continue
        others = sum(
            abs(math.log(measure(a, "frequency") / measure(b, "frequency")))
            for a, b in zip(after, base)
            if b is not item and a.kind == b.kind and measure(b, "frequency") > 0 and measure(a, "frequency") > 0
        )
        if item.kind.endswith("pair") and kind == "frequency":
            others += abs(math.log(measure(_tracked(transfer, nudged, item), "damping") / measure(item, "damping")))
        if own / (others + own * 1e-3 + 1e-300) > score:
            best, score = name, own / (others + own * 1e-3 + 1e-300)
    return best

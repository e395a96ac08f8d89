"""Moving a compensator's item (`compensator_items`) to a frequency, a damping or a gain:
by the one parameter that owns it (a bracketed root of the item's measure), or, where
the item is set by several parameters together (a polynomial's coefficients), by all of
them at once, keeping the gain and every other root where they are."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from engine.design.coefficient_moves import UNCHANGED, closed_form
from engine.design.compensator_items import NUDGE, Item, item_slopes, items, measure, named, readings
from engine.errors import EngineError
from engine.model.blocks import ExpressionTransfer
from engine.model.network import Network

Bounds = Mapping[str, tuple[float | None, float | None]]

GROWTH = 2.0  # the bracket around a parameter's value grows by this factor a step
BRACKET_STEPS = 40  # at most 2^40 either way
TOLERANCE = 1e-12  # relative, on the solved parameter
SECANT_STEPS = 8  # Newton-secant steps on log(measure) against log(parameter) before the bracket
SECANT_MISS = 1e-14  # the relative miss of the measure a secant step may stop at (Brent's: TOLERANCE on the parameter)
JOINT_EVALUATIONS = 400  # the most pole-zero forms a joint move may compute
JOINT_MISS = 1e-9  # the largest relative miss a joint move may leave on any root or the gain
APART = 1e3  # the miss charged per item when a trial's roots change structure
CLEAN = 1e-6  # a parameter moving the other measures this much relative to its item's moves it alone


@dataclass(frozen=True)
class Move:
    """An item moved by name: the parameters solved for and their values, the item's
    measure before (``now``) and asked (``target``), and the item's name after the move
    (``name``: items are numbered by frequency, so a zero moved past another of its kind
    is the other's number now)."""

    values: dict[str, float]
    now: float
    target: float
    name: str


def move_named(
    network: Network,
    params: Mapping[str, float],
    name: str,
    target: Callable[[float], float],
    bounds: Bounds | None = None,
) -> Move:
    """Move the item ``BLOCK.ITEM`` (its frequency, or the gain) or ``BLOCK.ITEM.zeta`` (a
    pair's damping) of a loop, items named as `named`, to ``target(now)`` (`moved`)."""
    labels = [e.label for e in network.entries if name.startswith(f"{e.label}.")]
    block = max(labels, key=len) if labels else name.partition(".")[0]  # a label may hold dots: vehicle.1
    item_name, _, suffix = name[len(block) + 1 :].partition(".")
    entry = next((e for e in network.entries if e.label == block), None)
    if entry is None or not isinstance(entry.transfer, ExpressionTransfer) or not entry.transfer.parameters:
        raise EngineError(f"{name}: no compensator block {block!r} (loopcraft analyze FILE lists them)")
    found = items(entry.transfer, params)
    names = named(found)
    if item_name not in names or suffix not in ("", "zeta"):
        raise EngineError(f"{name}: {block} has {', '.join(names)} (and ITEM.zeta for a pair's damping)")
    index = names.index(item_name)
    if suffix and not found[index].kind.endswith("pair"):
        raise EngineError(f"{name}: the {found[index].kind} has no damping (ITEM.zeta is a pair's)")
    kind = "damping" if suffix else "frequency"
    now = measure(found[index], kind)
    wanted = target(now)
    if not (math.isfinite(wanted) and wanted > 0):
        what = "gain" if found[index].kind == "gain" else kind
        raise EngineError(f"{name}: {wanted:g} is no {what}: it is a positive finite number (now {now:.6g})")
    try:
        values = moved(entry.transfer, params, index, wanted, kind, bounds, found)
        after = readings(entry.transfer, {**params, **values})
        there = _tracked(after, found[index], found)
    except EngineError as exc:
        raise EngineError(f"{name}: {exc}") from None
    renamed = named(after)[next(k for k, i in enumerate(after) if i is there)]
    return Move(values, now, wanted, f"{block}.{renamed}" + (f".{suffix}" if suffix else ""))


def moved(
    transfer: ExpressionTransfer,
    params: Mapping[str, float],
    index: int,
    target: float,
    kind: str = "frequency",
    bounds: Bounds | None = None,
    found: list[Item] | None = None,
) -> dict[str, float]:
    """The parameters, and their values, that bring item ``index`` (of `items`, given as
    ``found`` when read already) to ``target``: the frequency of a zero, pole or pair, the
    damping of a pair (``kind="damping"``), the value of the gain.  One parameter where one
    owns the item (the one that moves its measure most and the other items least); else
    the item's parameters together, the gain and every other root kept.  Within
    ``bounds``; an `EngineError` says why it cannot (a fixed item, a target out of reach)."""
    found = items(transfer, params) if found is None else found
    item = found[index]
    if not item.parameters:
        raise EngineError(f"the {item.kind} is fixed: no parameter moves it")
    name, clean, slope = _mover(transfer, params, found, index, kind)
    if clean:
        return {name: _solved(transfer, params, found, index, name, target, kind, bounds or {}, slope)}
    try:
        return _joint(transfer, params, found, index, target, kind, bounds or {})
    except EngineError:
        if name is None:
            raise
    return {name: _solved(transfer, params, found, index, name, target, kind, bounds or {}, slope)}


def _solved(
    transfer: ExpressionTransfer,
    params: Mapping[str, float],
    found: list[Item],
    index: int,
    name: str,
    target: float,
    kind: str,
    bounds,
    slope: float,
) -> float:
    """The value of ``name`` that brings item ``index``'s measure to ``target``, on
    log(measure) against u = log(parameter): Newton-secant steps from the nudge's
    ``slope`` (a corner 1/T, a gain K, a pair's sqrt: two pole-zero forms), else bracketed
    and Brent's method.  The item is followed past others of its kind (`_tracked`)."""
    item = found[index]
    value = params[name]
    if not value or not math.isfinite(value):
        raise EngineError(f"{name} is {value!r}: a value of 0 cannot be scaled to move the {item.kind}")
    low, high = bounds.get(name, (None, None))

    def miss(log_scale: float) -> float:
        moved = _tracked(readings(transfer, {**params, name: value * math.exp(log_scale)}), item, found)
        return math.log(measure(moved, kind)) - math.log(target)

    here = math.log(measure(item, kind)) - math.log(target)  # miss(0): the items read at params
    if here == 0:
        return value
    inside = _log_bounds(value, low, high)
    secant = _secant(miss, here, slope, inside)
    if secant is not None:
        return value * math.exp(secant)
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
                # scipy.optimize: 1.4 s to import, which the secant's and the closed form's moves never ask
                from scipy.optimize import brentq

                root = brentq(miss, min(0.0, step), max(0.0, step), xtol=TOLERANCE)
                return value * math.exp(root)
    raise EngineError(f"no value of {name} within its bounds brings the {item.kind}'s {kind} to {target:.6g}")


def _joint(
    transfer: ExpressionTransfer,
    params: Mapping[str, float],
    found: list[Item],
    index: int,
    target: float,
    kind,
    bounds,
) -> dict[str, float]:
    """The item's parameters solved together for the item at ``target`` with the gain and
    every other root unchanged: those that leave the gain alone first, then with the
    gain's own parameters (such as K), then with all the gain's."""
    item = found[index]
    held = set(found[0].parameters) if index else set()
    free = [n for n in item.parameters if params[n] and math.isfinite(params[n]) and _movable(bounds.get(n))]
    gain = [n for n in found[0].parameters if n not in free and params[n] and _movable(bounds.get(n))] if index else []
    alone = [n for n in gain if not any(n in i.parameters for i in found[1:])]  # the gain's own, such as K
    for unknowns in ([n for n in free if n not in held], free + alone, free + gain):
        if unknowns:
            try:
                return _least_squares(transfer, params, found, index, target, kind, bounds, unknowns)
            except EngineError as exc:
                failure = exc
    if not free:
        raise EngineError(f"the {item.kind}'s parameters ({', '.join(item.parameters)}) are all held")
    raise failure


def _least_squares(transfer, params, found, index, target, kind, bounds, unknowns: list[str]) -> dict[str, float]:
    """``unknowns`` solved (in log scale, within their bounds) for item ``index`` at
    ``target``, the gain and every other root unchanged."""
    item = found[index]
    counts, wanted = _goal(found, index, target, kind)
    start = np.array([params[n] for n in unknowns])

    def miss(u: np.ndarray) -> np.ndarray:
        trial = {**params, **dict(zip(unknowns, start * np.exp(u)))}
        try:
            shape, got = _signature(readings(transfer, trial))
        except EngineError:
            return np.full(wanted.size, APART)
        return got - wanted if shape == counts else np.full(wanted.size, APART)

    box = np.array([_log_bounds(v, *bounds.get(n, (None, None))) for n, v in zip(unknowns, start)]).T
    closed = _closed_form(transfer, params, item, _target_root(item, target, kind), unknowns, box)
    if closed is not None and np.max(np.abs(miss(closed))) <= JOINT_MISS:
        return {n: float(v) for n, v, u in zip(unknowns, start * np.exp(closed), closed) if abs(u) > TOLERANCE}
    from scipy.optimize import least_squares  # imported here: see `_solved`

    fit = least_squares(
        miss,
        np.zeros(len(unknowns)),
        bounds=(box[0], box[1]),
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
        max_nfev=JOINT_EVALUATIONS,
    )
    if np.max(np.abs(miss(fit.x))) > JOINT_MISS:
        held = "the gain and the other roots kept"
        raise EngineError(
            f"no values of {', '.join(unknowns)} within their bounds bring the {item.kind}'s {kind} to {target:.6g} "
            f"({held})"
        )
    return {n: float(v) for n, v, u in zip(unknowns, start * np.exp(fit.x), fit.x) if abs(u) > TOLERANCE}


def _goal(found: list[Item], index: int, target: float, kind: str) -> tuple[tuple[int, ...], np.ndarray]:
    """The signature (`_signature`) of the items with item ``index`` moved to ``target``."""
    item = found[index]
    return _signature([*found[:index], Item(item.kind, _target_root(item, target, kind), ()), *found[index + 1 :]])


def _target_root(item: Item, target: float, kind: str) -> complex:
    """Item's root (the gain's value) with its frequency, damping or gain at ``target``."""
    w, zeta = abs(item.root), _damping(item)  # signed: a right-half-plane pair keeps its side
    if kind == "damping":
        zeta = target
    else:
        w = target
    root = complex(-zeta * w, w * math.sqrt(max(1 - zeta * zeta, 0.0))) if item.kind.endswith("pair") else -w
    if item.kind == "gain":
        root = complex(math.copysign(target, item.root.real))
    elif item.root.real > 0 and not item.kind.endswith("pair"):
        root = w
    return complex(root)


def _closed_form(
    transfer, params, item: Item, root: complex, unknowns: list[str], box: np.ndarray
) -> np.ndarray | None:
    """The move in closed form (`coefficient_moves`, a compensator typed by its polynomial
    coefficients) as the least squares' log-scaled ``unknowns``; None where it changes
    another parameter, a coefficient's sign, or leaves the bounds (the least squares then)."""
    values = closed_form(transfer, params, item.kind, item.root, root)
    if values is None:
        return None
    largest = max(abs(v) for v in values.values())
    if any(abs(v - params[n]) > UNCHANGED * largest for n, v in values.items() if n not in unknowns):
        return None
    ratios = np.array([values.get(n, params[n]) / params[n] for n in unknowns])
    if not np.all(ratios > 0):
        return None
    u = np.log(ratios)
    return u if np.all((box[0] <= u) & (u <= box[1])) else None


KINDS = ("zero", "pole", "zero pair", "pole pair", "integrator", "differentiator")


def _signature(found: list[Item]) -> tuple[tuple[int, ...], np.ndarray]:
    """How many items of each kind, and the log of the gain's size then for each kind in
    turn the sorted log frequencies and, for pairs, the (signed) dampings: what a joint
    move holds (or moves)."""
    out = [math.log(abs(found[0].root.real) or 1e-300)]
    counts = []
    for kind in KINDS:
        same = sorted((i for i in found if i.kind == kind), key=lambda i: abs(i.root))
        counts.append(len(same))
        out += [math.log(abs(i.root) or 1.0) for i in same]
        out += [_damping(i) for i in same if kind.endswith("pair")]  # signed
    return tuple(counts), np.array(out)


def _secant(miss: Callable[[float], float], here: float, slope: float, inside: tuple[float, float]) -> float | None:
    """The root of ``miss`` (``here`` at 0, about ``slope`` there) by Newton's step then
    secant steps, within ``inside``; None when a step leaves it, a form fails or
    `SECANT_STEPS` do not bring the miss within `SECANT_MISS` (the bracket then takes over)."""
    if not (math.isfinite(slope) and slope):
        return None
    u0, f0, u1 = 0.0, here, -here / slope
    for _ in range(SECANT_STEPS):
        if not inside[0] <= u1 <= inside[1]:
            return None
        try:
            f1 = miss(u1)
        except (EngineError, ValueError):
            return None
        if abs(f1) <= SECANT_MISS:
            return u1
        if not math.isfinite(f1) or f1 == f0:
            return None
        u0, f0, u1 = u1, f1, u1 - f1 * (u1 - u0) / (f1 - f0)
    return None


def _movable(bound: tuple[float | None, float | None] | None) -> bool:
    """Is a parameter free to move (not held by equal bounds)?"""
    return bound is None or bound[0] is None or bound[1] is None or bound[0] < bound[1]


def _log_bounds(value: float, low: float | None, high: float | None) -> tuple[float, float]:
    """The bounds on u for value * exp(u) within [low, high] (``value`` nonzero)."""
    lo, hi = -np.inf, np.inf
    for bound, is_low in ((low, True), (high, False)):
        if bound is None or not math.isfinite(bound) or bound / value <= 0:
            continue
        u = math.log(bound / value)
        if is_low == (value > 0):
            lo = max(lo, u)
        else:
            hi = min(hi, u)
    return lo, hi


def _damping(item: Item) -> float:
    """A pair's damping with its sign (negative in the right half-plane)."""
    return -item.root.real / abs(item.root)


def _tracked(found: list[Item], like: Item, base: list[Item]) -> Item:
    """Item ``like`` of ``base`` among ``found`` (the items after a change): of its kind,
    each other item of ``base`` takes the nearest of ``found`` first, and of those left
    the nearest ``like`` is it (a zero moved past another of its kind stays itself while
    the other stays put)."""
    same = [i for i in found if i.kind == like.kind]
    if not same:
        raise EngineError(f"the {like.kind} is gone at these values")
    if like.kind == "gain":
        return same[0]
    for other in base:
        if other is not like and other.kind == like.kind and len(same) > 1:
            same.remove(min(same, key=lambda i: _apart(i, other)))
    return min(same, key=lambda i: _apart(i, like))


def _apart(a: Item, b: Item) -> float:
    """How far apart two items are, in log frequency."""
    return abs(math.log(abs(a.root) or 1e-300) - math.log(abs(b.root) or 1e-300))


def _mover(
    transfer: ExpressionTransfer, params: Mapping[str, float], base: list[Item], index: int, kind: str
) -> tuple[str | None, bool, float]:
    """Of the parameters that move item ``index``, the one that moves its measure most
    relative to how much it moves the others (None where none moves it alone), whether
    it leaves the others where they are, and d log(measure) / d log(parameter) there
    (exact derivatives, `item_slopes`; a parameter without them is nudged)."""
    item = base[index]
    shared = {n for i in base if i is not item and i.kind != "gain" for n in i.parameters}
    own = [n for n in item.parameters if n not in shared]
    if not own and item.kind == "gain":
        raise EngineError("no one parameter sets the gain alone: write the compensator as K*(...) with a gain K")
    best, score, slope = (own[0] if own else None), (-math.inf, math.inf), math.nan
    exact = item_slopes(transfer, params, base)
    for name in own:
        try:
            if name in exact:
                signed, others = _exact_change(base, index, exact[name], kind)
            else:
                signed, others = _nudged_change(transfer, params, base, index, kind, name)
        except (EngineError, ValueError, ZeroDivisionError):
            continue
        change = abs(signed)
        ratio = change / (others + change * 1e-3 + 1e-300)
        if ratio > score[0]:
            best, score, slope = name, (ratio, others / (change + 1e-300)), signed
    return best, score[1] <= CLEAN, slope


def _exact_change(base: list[Item], index: int, row: list[complex], kind: str) -> tuple[float, float]:
    """d log(measure) / d log x of item ``index`` and the sum of the other items' |d log
    frequency / d log x| (and a pair's relative damping's), from ``row`` (`item_slopes`)."""
    item = base[index]
    if measure(item, kind) <= 1e-300:
        raise ValueError("no measure to move")
    damping = _damping(item) if item.kind.endswith("pair") else 0.0
    if kind == "damping":
        signed = _damping_slope(item, row[index]) / damping if damping > 1e-300 else 0.0
    else:
        signed = _log_frequency_slope(item, row[index])
    others = sum(
        abs(_log_frequency_slope(b, dr)) for k, (b, dr) in enumerate(zip(base, row)) if k != index and measure(b) > 0
    )
    if item.kind.endswith("pair") and kind == "frequency":
        others += abs(_damping_slope(item, row[index])) / max(abs(damping), 1e-9)
    return signed, others


def _log_frequency_slope(item: Item, slope: complex) -> float:
    """d log|root| from d root (the gain's d log(gain), as given)."""
    return slope.real if item.kind == "gain" else (slope / item.root).real


def _damping_slope(item: Item, slope: complex) -> float:
    """d zeta from d root, zeta = -Re r / |r|."""
    r = item.root
    return -slope.real / abs(r) + r.real * (slope / r).real / abs(r)


def _nudged_change(
    transfer: ExpressionTransfer, params: Mapping[str, float], base: list[Item], index: int, kind: str, name: str
) -> tuple[float, float]:
    """`_exact_change` by nudging ``name`` (`NUDGE`): a parameter at 0, a repeated root."""
    item, value = base[index], params[name]
    after = readings(transfer, {**params, name: value * (1 + NUDGE) if value else NUDGE})
    signed = math.log(measure(_tracked(after, item, base), kind) / measure(item, kind))
    others = sum(
        abs(math.log(measure(a, "frequency") / measure(b, "frequency")))
        for a, b in zip(after, base)
        if b is not item and a.kind == b.kind and measure(b, "frequency") > 0 and measure(a, "frequency") > 0
    )
    if item.kind.endswith("pair") and kind == "frequency":
        before, now = _damping(item), _damping(_tracked(after, item, base))
        others += abs(now - before) / max(abs(before), 1e-9)  # signed: a right-half-plane pair's too
    return signed / math.log1p(NUDGE), others / math.log1p(NUDGE)

"""A compensator as the engineer reads it: its gain (the Bode gain, with every factor
written as (1 + s/w)), its real zeros and poles as corner frequencies and time
constants, its complex pairs as (wn, zeta), its integrators and differentiators, and
for each the parameters that move it (a root belongs to a parameter whose derivative
dr/dx = -(dp/dx)(r) / p'(r), p the tree's numerator or denominator, is not zero beside the
root's size; a repeated root or a parameter at 0 is read by nudging it, `NUDGE`).  Moving an
item is `compensator_moves`."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from engine.derived import Form
from engine.errors import EngineError
from engine.model.bilinear import s_equivalent
from engine.model.blocks import ExpressionTransfer
from engine.model.factor_text import root_factors, time_constant_factor
from engine.model.factored import PoleZero, pole_zero
from engine.model.network import Network
from engine.model.paired_product import PairedProduct

NUDGE = 1e-6  # relative change of a parameter that tells which roots it moves, where no derivative is exact
MOVED = 1e-9  # relative change of a root (or the gain) under a nudge that counts as moved
OWNS = 1e-10  # |x dr/dx| beside |r| (and d log gain / d log x) above rounding: x moves it (x = 0: dr/dx)
SIMPLE = 1e-2  # a root whose tangent misses p by more than this at PROBE beside it is not simple
PROBE = 1e-5  # relative distance from a root at which its tangent is checked
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
    """The gain, then the zeros and poles of a block, low frequency first.  Kept on the block's
    expression at its parameters' values (`Expression.at`; a missing one is a `ParameterError`
    naming it): a nudge reads its block's items where the shaping table read them after the
    nudge before."""
    return list(transfer.expression.at(ITEMS, params, lambda: _items_at(transfer, params)))


ITEMS: Form[tuple[Item, ...]] = Form("compensator items")


def _items_at(transfer: ExpressionTransfer, params: Mapping[str, float]) -> tuple[Item, ...]:
    """`items`, made."""
    base, exact = _exact_at(transfer, params)
    scale = _scale(base)
    gain = _bode_gain(base, scale)
    moved = {
        name: _owned(exact[name], params[name], base, scale, gain)
        if name in exact
        else _moved(transfer, params, name, base, scale, gain)
        for name in transfer.parameters
    }
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


def item_slopes(
    transfer: ExpressionTransfer, params: Mapping[str, float], found: list[Item]
) -> dict[str, list[complex]]:
    """By each parameter x whose derivatives are exact (`_slopes`), d(root)/d log x of every
    item of ``found`` (`items` at ``params``; the gain's: d log(Bode gain)/d log x; nan for a
    root at the origin)."""
    base, exact = _exact_at(transfer, params)
    out = {}
    for name, (dz, dp, log_gain) in exact.items():
        x, row = params[name], []
        for item in found:
            zero = item.kind.startswith(("zero", "differentiator"))
            roots, slopes = (base.zeros, dz) if zero else (base.poles, dp)
            at = np.flatnonzero(roots == item.root)
            row.append(
                log_gain * x if item.kind == "gain" else complex(slopes[at[0]] * x) if at.size else complex("nan")
            )
        out[name] = row
    return out


Slopes = tuple[np.ndarray, np.ndarray, complex]  # dz/dx, dp/dx, d log(Bode gain)/dx
EXACT: Form[tuple[PoleZero, dict[str, Slopes]]] = Form("pole-zero form and exact slopes")


def _exact_at(transfer: ExpressionTransfer, params: Mapping[str, float]) -> tuple[PoleZero, dict[str, Slopes]]:
    """A block's pole-zero form and `_slopes` at its parameters' values, kept on its expression
    as `items` are (a move reads them where the shaping table's items did)."""

    def made() -> tuple[PoleZero, dict[str, Slopes]]:
        base = pole_zero(transfer.expression, params)
        return base, _slopes(transfer, params, base, _scale(base))

    return transfer.expression.at(EXACT, params, made)


def _slopes(transfer: ExpressionTransfer, params: Mapping[str, float], base, scale: float) -> dict[str, Slopes]:
    """Each parameter's exact derivatives of the zeros, the poles and the log of the Bode gain,
    for the parameters that have them: every root simple (`_simple`), the parameter not 0 (a
    leading coefficient at 0 adds a root) and no root at the origin moved by it."""
    roots = np.concatenate([base.zeros, base.poles])
    n, origin = roots.size, np.abs(roots) <= ORIGIN * scale
    size = np.maximum(np.abs(roots), ORIGIN * scale)
    probe = roots + PROBE * size
    s0 = _away(roots, scale)
    num, den = transfer.expression.fraction(np.concatenate([roots, probe, [s0]]), params)
    if not _simple(num, den, roots, probe, base.zeros.size):
        return {}
    slope = _rows(num.dvar, den.dvar, base.zeros.size, n)
    weights = 1.0 / (s0 - roots) + np.divide(1.0, roots, out=np.zeros(n, dtype=complex), where=~origin)
    sign = np.where(np.arange(n) < base.zeros.size, 1.0, -1.0)
    out = {}
    for name in transfer.parameters:
        nothing = np.zeros(n + n + 1, dtype=complex)
        d_num, d_den = num.grad.get(name, nothing), den.grad.get(name, nothing)
        dr = -_rows(d_num, d_den, base.zeros.size, n) / slope
        if params[name] == 0 or np.any(origin & (np.abs(dr * params[name]) > OWNS * size)):
            continue
        log_gain = d_num[-1] / num.value[-1] - d_den[-1] / den.value[-1] + np.sum(sign * dr * weights)
        if not np.isfinite(log_gain):
            continue
        out[name] = (dr[: base.zeros.size], dr[base.zeros.size :], complex(log_gain))
    return out


def _rows(at_num: np.ndarray, at_den: np.ndarray, zeros: int, n: int) -> np.ndarray:
    """Of values at the roots (the zeros, then the poles), the numerator's at the zeros and the
    denominator's at the poles."""
    return np.concatenate([at_num[:zeros], at_den[zeros:n]])


def _simple(num, den, roots: np.ndarray, probe: np.ndarray, zeros: int) -> bool:
    """Is every root a simple root of its polynomial, found to better than `PROBE`: p(r) small
    beside p'(r) PROBE r, and its tangent meets p at the probe beside it within `SIMPLE`."""
    n = roots.size
    value, slope = _rows(num.value, den.value, zeros, n), _rows(num.dvar, den.dvar, zeros, n)
    step = slope * (probe - roots)
    at_probe = _rows(num.value[n:], den.value[n:], zeros, n)
    with np.errstate(all="ignore"):
        tangent = np.abs(at_probe - value - step) <= SIMPLE * np.abs(step)
        accurate = np.abs(value) <= np.abs(step)
    finite = np.all(np.isfinite(num.value)) and np.all(np.isfinite(den.value)) and np.all(np.isfinite(slope))
    return bool(finite and np.all(tangent & accurate))


def _away(roots: np.ndarray, scale: float) -> complex:
    """A point of the size of the roots, a tenth of ``scale`` or more from every root (where
    the gain's derivative is read), or the last tried."""
    point = 0j
    for angle in (2.0, 2.5, 1.5, 2.9, 0.5):
        point = scale * complex(math.cos(angle), math.sin(angle))
        if not roots.size or np.min(np.abs(roots - point)) >= 0.1 * scale:
            break
    return point


def _owned(slopes: Slopes, value: float, base, scale: float, gain: float) -> tuple:
    """`_moved` read from exact derivatives: moved where |x dr/dx| exceeds `OWNS` beside the root."""
    dz, dp, log_gain = slopes
    moves_gain = abs(log_gain * value) > OWNS if gain else True

    def which(roots: np.ndarray, dr: np.ndarray) -> list[bool]:
        return [bool(v) for v in np.abs(dr * value) > OWNS * np.maximum(np.abs(roots), ORIGIN * scale)]

    return moves_gain, which(base.zeros, dz), which(base.poles, dp)


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

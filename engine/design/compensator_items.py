"""A compensator as the engineer reads it: its gain (the Bode gain, with every factor
written as (1 + s/w)), its real zeros and poles as corner frequencies and time
constants, its complex pairs as (wn, zeta), its integrators and differentiators, and
for each the parameters that move it (found by nudging each parameter: a root that
moves belongs to it)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from engine.errors import EngineError
from engine.model.blocks import ExpressionTransfer
from engine.model.factored import pole_zero

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

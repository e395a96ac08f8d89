"""A root of a compensator typed by its polynomial coefficients (cip's form: N(s)/D(s), each
term c s^k with c a parameter or a number) moved in closed form: its polynomial times the
new root's factor over the old one's, scaled so that the Bode gain stays, every other root
where it was.  One pole-zero form checks it (`compensator_moves`), where the least squares
over the coefficients took about fifteen."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from engine.model.blocks import ExpressionTransfer
from engine.model.expressions import Node
from engine.model.factored import monomial, signed_terms

Coefficients = list[tuple[float, str | float]]  # ascending powers: (sign, a parameter's name or a number)
UNCHANGED = 1e-12  # relative to the largest coefficient: a number (or a held parameter) the move leaves as it is


def typed_sides(transfer: ExpressionTransfer) -> tuple[Coefficients, Coefficients] | None:
    """The numerator's and the denominator's coefficients of a ratio of polynomials typed by
    their coefficients (each power once); None for any other expression."""
    root = transfer.expression.root
    sides = (root.args[0], root.args[1]) if root.op == "div" else (root, None)
    out = []
    for side in sides:
        coefficients = [(1.0, 1.0)] if side is None else _coefficients(side)
        if coefficients is None:
            return None
        out.append(coefficients)
    return out[0], out[1]


def _coefficients(side: Node) -> Coefficients | None:
    by_power: dict[int, tuple[float, str | float]] = {}
    for sign, term in signed_terms(side):
        typed = monomial(term)
        if typed is None or typed[1] in by_power:
            return None
        node, power = typed
        by_power[power] = (sign, 1.0 if node is None else node.name if node.op == "param" else node.value)
    return [by_power.get(k, (1.0, 0.0)) for k in range(max(by_power) + 1)]


def closed_form(
    transfer: ExpressionTransfer, params: Mapping[str, float], kind: str, old: complex, new: complex
) -> dict[str, float] | None:
    """The coefficients' values (by parameter name, every parameter of the root's polynomial)
    that move the ``kind`` (zero, pole, zero pair, pole pair) at ``old`` to ``new``, the Bode
    gain and every other root kept; None where the compensator is not so typed, a parameter
    appears twice, or a number among the coefficients would have to change."""
    sides = typed_sides(transfer)
    if sides is None or kind not in ("zero", "pole", "zero pair", "pole pair"):
        return None
    side = sides[0] if kind.startswith("zero") else sides[1]
    other = sides[1] if kind.startswith("zero") else sides[0]
    names = [name for _, name in side if isinstance(name, str)]
    if len(set(names)) != len(names) or set(names) & {name for _, name in other if isinstance(name, str)}:
        return None
    now = np.array([sign * (params[c] if isinstance(c, str) else c) for sign, c in side])[::-1]  # descending
    if now[0] == 0:
        return None
    pair = kind.endswith("pair")
    before, after = (np.poly([r, r.conjugate()] if pair else [r]).real for r in (old, new))
    quotient, _ = np.polydiv(now, before)
    scale = (abs(old) / abs(new)) ** (2 if pair else 1)
    moved = (np.polymul(quotient, after) * scale)[::-1]  # ascending
    largest = float(np.max(np.abs(moved)))
    values = {}
    for (sign, coefficient), value in zip(side, moved.tolist()):
        if isinstance(coefficient, str):
            values[coefficient] = value / sign
        elif abs(value - sign * coefficient) > UNCHANGED * largest:
            return None
    return values

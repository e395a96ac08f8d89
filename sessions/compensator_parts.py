"""Parts a designer adds to a compensator, and deleting one of its items (issue 38,
section 1).  A part is a product of factors in time-constant form, its parameters named
for what they are (``lead1_Tz``, ``notch1_wz``) and placed about a frequency (the
crossover): a lead's zero a third of it and its pole three times it, a lag a decade and
two below, a notch on it.  The compensator's expression gains the part's factors as
typed (`engine.model.factor_text`), in every condition whose block reads the same, and
the parameters join the session's.  Deleting an item removes the factor with the fewest
roots that holds it, the parameters nothing else names, and the constraints and equalities on them."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from dataclasses import dataclass

from engine.errors import EngineError
from engine.model.blocks import ExpressionTransfer
from engine.model.factor_text import Product, product
from engine.model.factored import pole_zero
from sessions.errors import SessionError
from sessions.format.schema import ParameterModel, ProblemModel

SPAN = 1e4  # a new time constant or frequency may move this factor either way (its bounds)


@dataclass(frozen=True)
class Part:
    """A part: what it is, its factors (``{name}`` fields for its parameters), and each
    parameter's start value as a function of the frequency w it is placed about."""

    title: str
    over: tuple[str, ...]
    under: tuple[str, ...]
    starts: dict[str, Callable[[float], float]]


PARTS: dict[str, Part] = {
    "lead": Part(
        "lead: zero at w/3, pole at 3w (+53 deg at w)",
        ("1+{Tz}*s",),
        ("1+{Tp}*s",),
        {"Tz": lambda w: 3 / w, "Tp": lambda w: 1 / (3 * w)},
    ),
    "lag": Part(
        "lag: zero at w/10, pole at w/100 (-20 dB above them)",
        ("1+{Tz}*s",),
        ("1+{Tp}*s",),
        {"Tz": lambda w: 10 / w, "Tp": lambda w: 100 / w},
    ),
    "int": Part("integrator: a PI, 1 + wi/s, its zero at wi = w/10", ("1+{wi}/s",), (), {"wi": lambda w: w / 10}),
    "zero": Part("real zero at w", ("1+{T}*s",), (), {"T": lambda w: 1 / w}),
    "pole": Part("real pole at 10 w", (), ("1+{T}*s",), {"T": lambda w: 1 / (10 * w)}),
    "notch": Part(
        "notch at w: zeros zeta 0.05, poles zeta 0.5",
        ("1+2*{zz}*s/{wz}+(s/{wz})^2",),
        ("1+2*{zp}*s/{wp}+(s/{wp})^2",),
        {"wz": lambda w: w, "zz": lambda w: 0.05, "wp": lambda w: w, "zp": lambda w: 0.5},
    ),
    "pair": Part(
        "complex pole pair at 10 w, zeta 0.5",
        (),
        ("1+2*{zeta}*s/{wn}+(s/{wn})^2",),
        {"wn": lambda w: 10 * w, "zeta": lambda w: 0.5},
    ),
}
DAMPING_BOUNDS = (1e-4, 5.0)


def add_part(
    draft: ProblemModel,
    block: str,
    kind: str,
    w: float,
    given: dict[str, float] | None = None,
    condition: int = 0,
) -> list[str]:
    """Add the part ``kind`` to the compensator ``block`` of every condition where it
    reads as in ``condition``, placed about ``w`` rad/s (``given``: start values of some
    of its parameters, by field): the new parameters' names."""
    part = PARTS[kind]
    if not (w > 0 and math.isfinite(w)):
        raise SessionError(f"the {kind} is placed about a frequency: {w!r} rad/s is not one")
    taken = {p.name for p in draft.parameters}
    n = next(k for k in range(1, 10_000) if not any(n.startswith(f"{kind}{k}_") for n in taken))
    names = {field: f"{kind}{n}_{field}" for field in part.starts}
    values = {field: start(w) for field, start in part.starts.items()} | (given or {})
    added = Product(tuple(f.format(**names) for f in part.over), tuple(f.format(**names) for f in part.under))
    for transfer in _transfers(draft, block, condition):
        transfer.expression = product(transfer.expression).times(added).text
    for field, name in names.items():
        low, high = DAMPING_BOUNDS if field.startswith("z") else (values[field] / SPAN, values[field] * SPAN)
        draft.parameters.append(ParameterModel(name=name, value=values[field], min=low, max=high, sign="positive"))
    return list(names.values())


def notch_on(draft: ProblemModel, block: str, frequency: float, damping: float, condition: int = 0) -> list[str]:
    """A notch whose zeros sit on a resonance (its frequency and damping: they cancel its
    poles exactly at these values), its poles at the same frequency damped 0.5."""
    return add_part(draft, block, "notch", frequency, {"zz": max(damping, DAMPING_BOUNDS[0])}, condition)


def remove_item(
    draft: ProblemModel, block: str, values: dict[str, float], root: complex, kind: str, condition: int = 0
) -> list[str]:
    """Delete the item (a zero or pole, ``kind``; ``root`` its upper root) from the
    compensator ``block`` of every condition where it reads as in the first: the factor
    with the fewest roots that holds it goes (with the other roots it has: the first line
    says which), with the parameters no other factor uses and the constraints on them.
    What went, one line each."""
    transfers = _transfers(draft, block, condition)
    found = product(transfers[0].expression)
    held = [
        (len(r), k, over)
        for over, side in ((True, found.numerator), (False, found.denominator))
        for k, f in enumerate(side)
        if (r := _roots(f, values)) and _holds(r, root)
    ]
    if not held:
        raise SessionError(f"{block}: no factor of {transfers[0].expression} holds the {kind}")
    _, index, over = min(held)
    side = found.numerator if over else found.denominator
    roots = _roots(side[index], values)
    kept = found.without(over=index) if over else found.without(under=index)
    text = kept.text
    for transfer in transfers:
        transfer.expression = text
    gone = [p.name for p in draft.parameters if p.name in ExpressionTransfer(side[index]).parameters]
    gone = [n for n in gone if not _still_named(draft, n)]
    draft.parameters[:] = [p for p in draft.parameters if p.name not in gone]
    also = f", with its other roots {', '.join(f'{r:.4g}' for r in roots if abs(r - root) > 1e-9 * abs(root))}"
    lines = [f"{block}: the factor {side[index]} goes{also if len(roots) > 1 + bool(root.imag) else ''} -> {text}"]
    lines += [f"parameter {n} goes" for n in gone]
    for c in list(draft.constraints):
        if any(_names(str(c), n) for n in gone):
            draft.constraints.remove(c)
            lines.append(f"constraint {c} goes")
    for e in list(draft.equalities):
        if any(_names(term, n) for term in e.terms for n in gone):
            draft.equalities.remove(e)
            lines.append(f"equality {' + '.join(f'{v:g}*{t}' for t, v in e.terms.items())} = {e.value:g} goes")
    return lines


def _still_named(draft: ProblemModel, name: str) -> bool:
    """Does anything but the parameters, constraints and equalities (which go with it)
    still name ``name``: a block's expression or coefficient in any condition?"""
    text = json.dumps(draft.model_dump(mode="json", exclude={"parameters", "constraints", "equalities"}))
    return _names(text, name)


def _names(text: str, name: str) -> bool:
    return re.search(rf"(?<![A-Za-z0-9_]){re.escape(name)}(?![A-Za-z0-9_])", text) is not None


def _roots(factor: str, values: dict[str, float]) -> list[complex]:
    """A factor's zeros and poles (none when it cannot be read at these values)."""
    try:
        form = pole_zero(ExpressionTransfer(factor).expression, values)
    except EngineError:
        return []
    return [complex(r) for r in [*form.zeros, *form.poles]]


def _holds(roots: list[complex], root: complex) -> bool:
    return any(abs(r - root) <= 1e-9 * abs(root) for r in roots)


def _transfers(draft: ProblemModel, block: str, condition: int = 0) -> list:
    """The expression transfers of ``block`` in every condition that reads as it does in
    ``condition`` (the one the shaping table shows), that one first."""
    found = [
        b.transfer
        for c in draft.conditions[condition : condition + 1] + draft.conditions
        if c.plant.format == "diagram"
        for b in c.plant.blocks
        if b.name == block and getattr(b.transfer, "kind", "") == "expression"
    ]
    if not found:
        raise SessionError(
            f"{block}: parts are added to an expression block of a diagram (this compensator is another form: edit "
            "it in the Plant tab)"
        )
    return list({id(t): t for t in found if t.expression == found[0].expression}.values())

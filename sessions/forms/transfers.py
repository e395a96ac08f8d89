"""The one-line text of every transfer kind, read and written as a pair.

``format_transfer(t)`` writes a block's definition so that
``parse_transfer(text, variable)`` reads it back to the same model.  A
structured kind is named before a colon; any other text is an expression,
so a factored block can be retyped as the expression it equals:

    factored: gain 16000; s^-1; zeros (s+8); poles (s+20) (1+0.5s) sos(0.7, 12)
    controller: gain K; s^-1; zero 0.5; pole b2; complex_pole 0.3 40
    polynomial: num 1, 2; den 1, 3, 2; ascending
    delay: tau
    table: inlet.csv columns f,mag,ph polar hz gain 1     (table: inline polar hz gain 1)
    state_space: plant.npz                                (state_space: inline)
    10*(s+1)/(s*(s+5))

A state space is replaced as a whole: by a file's name, or ``inline`` to keep
its matrices; the Plant table shows it by its order, poles and zeros
(`describe_state_space`).

Coefficients are numbers or parameter names.  The text of a factored block's
factors uses the block's variable (``(w+8)`` in a w-plane condition)."""

from __future__ import annotations

import cmath
import re

from pydantic import ValidationError

from engine.errors import EngineError
from engine.model.blocks import StateSpaceTransfer
from sessions.format.checks import invalid, invalid_what
from sessions.format.schema import (
    ControllerBlock,
    ControllerFactorModel,
    DelayBlock,
    DiscretizedBlock,
    ExpressionBlock,
    FactoredBlock,
    FactorModel,
    PolynomialBlock,
    StateSpaceBlock,
    TableBlock,
)
from sessions.forms.one_line import FormError, format_number, parse_expression, parse_number

KINDS = ("factored", "controller", "polynomial", "delay", "table", "state_space", "discretized")
SHOWN_ROOTS = 8  # poles (and zeros) a state space's line lists, the slowest first
NAME = r"[A-Za-z_][A-Za-z0-9_]*"
COEF = rf"(?:{NAME}|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"


def format_coefficient(value: float | str) -> str:
    """A coefficient: a parameter's name as it is, a number exactly."""
    return value if isinstance(value, str) else format_number(value)


def parse_coefficient(text: str, what: str = "a coefficient") -> float | str:
    """A number or a parameter name."""
    text = text.strip()
    if re.fullmatch(NAME, text) and text.lower() not in ("inf", "nan", "infinity"):
        return text
    value = parse_number(text, f"{what} (a number or a parameter name)")
    if value in (float("inf"), float("-inf")):
        raise FormError(f"{what} must be finite")
    return value


def format_transfer(t, variable: str = "s") -> str:
    """The editable one-line text of a transfer model (kind-prefixed unless an expression)."""
    if t.kind == "expression":
        return t.expression
    return f"{t.kind}: {describe_transfer(t, variable)}"


def describe_transfer(t, variable: str = "s") -> str:
    """The definition without its kind: what the Plant table shows."""
    c = format_coefficient
    if t.kind == "expression":
        return t.expression
    if t.kind == "factored":
        items = [f"gain {c(t.gain)}"] + ([f"{variable}^{t.s_power}"] if t.s_power else [])
        items += [
            f"{side} " + " ".join(_factor_text(f, variable) for f in getattr(t, side))
            for side in ("zeros", "poles")
            if getattr(t, side)
        ]
        return "; ".join(items)
    if t.kind == "controller":
        items = [f"gain {c(t.gain)}"] + ([f"{variable}^{t.s_power}"] if t.s_power else [])
        items += [
            f"{f.kind} {c(f.b)}" if f.kind in ("zero", "pole") else f"{f.kind} {c(f.damping)} {c(f.frequency)}"
            for f in t.factors
        ]
        return "; ".join(items)
    if t.kind == "polynomial":
        return f"num {', '.join(map(c, t.numerator))}; den {', '.join(map(c, t.denominator))}; {t.order}"
    if t.kind == "delay":
        return c(t.tau)
    if t.kind == "state_space":
        return "inline" if t.file is None else t.file
    if t.kind == "discretized":
        extra = [f"delay {format_number(t.delay)}"] if t.delay else []
        extra += [f"prewarp {format_number(t.prewarp)}"] if t.prewarp is not None else []
        return "; ".join([t.expression, t.method, *extra])
    table = t.table
    source = f"{table.csv} columns {','.join(table.columns or [])}" if table.csv else "inline"
    return f"{source} {table.form} {table.unit} gain {format_number(table.gain)}"


def describe_state_space(transfer: StateSpaceTransfer, in_z: bool = False) -> str:
    """'state space, order 12: poles ..., zeros ...' (a pair once, as a +- b j; the slowest
    `SHOWN_ROOTS` of each, and how many more; a block of several ports: its poles); ``in_z``: a sampled loop's block (its w-plane
    form's roots shown in z)."""
    from engine.model.bilinear import z_of_w
    from engine.model.ports.state_space_ports import StateSpaceChannel

    if isinstance(transfer, StateSpaceChannel):  # a block of several ports: its modes, once
        block, where = transfer.block, " in z" if in_z else ""
        poles = z_of_w(block.poles) if in_z else block.poles
        return f"state space, order {block.order}, {block.ports} inputs and outputs: poles{where} {_roots_text(poles)}"
    try:
        form = transfer.form
    except EngineError as exc:
        return f"state space, order {transfer.order}: {exc}"
    poles, zeros = (z_of_w(form.poles), z_of_w(form.zeros)) if in_z else (form.poles, form.zeros)
    zeros = [z for z in zeros if cmath.isfinite(z)]  # a w-plane zero at w = 1 is z = inf
    where = " in z" if in_z else ""
    return f"state space, order {transfer.order}: poles{where} {_roots_text(poles)}, zeros {_roots_text(zeros)}"


def _roots_text(roots) -> str:
    upper = sorted((r for r in roots if r.imag >= 0), key=abs)
    if not upper:
        return "none"
    shown = [f"{r.real:.4g}" if r.imag == 0 else f"{r.real:.4g}+-{r.imag:.4g}j" for r in upper[:SHOWN_ROOTS]]
    more = f" and {len(upper) - SHOWN_ROOTS} more" if len(upper) > SHOWN_ROOTS else ""
    return " ".join(shown) + more


def _factor_text(f: FactorModel, x: str) -> str:
    c = format_coefficient
    if f.kind == "root":
        a = f.a
        sign = "-" if isinstance(a, float) and a < 0 else "+"
        return f"({x}{sign}{c(abs(a)) if isinstance(a, float) else a})"
    if f.kind == "time_constant":
        return f"(1+{c(f.T)}{'*' if isinstance(f.T, str) else ''}{x})"
    return f"sos({c(f.zeta)}, {c(f.omega)})"


def parse_transfer(text: str, variable: str, current=None):
    """A transfer model from its one-line text; ``current`` supplies an inline
    table's data when a table line is retyped."""
    head, sep, body = text.partition(":")
    kind = head.strip().lower()
    if not sep or kind not in KINDS:
        return ExpressionBlock(kind="expression", expression=parse_expression(text, variable))
    readers = {
        "factored": _factored,
        "controller": _controller,
        "polynomial": _polynomial,
        "delay": _delay,
        "table": _table,
        "state_space": _state_space,
        "discretized": _discretized,
    }
    try:
        return readers[kind](body, variable, current)
    except ValidationError as exc:
        raise FormError(f"{kind}: {invalid(exc, top='')}") from None


def _items(body: str) -> list[tuple[str, str]]:
    """The ';'-separated items of a definition as (first word, rest)."""
    out = []
    for part in (p.strip() for p in body.split(";")):
        if part:
            word, _, rest = part.partition(" ")
            out.append((word.lower(), rest.strip()))
    return out


def _power(word: str, variable: str) -> int | None:
    match = re.fullmatch(rf"{re.escape(variable)}\^?([-+]?\d+)", word)
    return int(match.group(1)) if match else None


def _factored(body: str, variable: str, _current) -> FactoredBlock:
    values: dict = {"kind": "factored", "zeros": [], "poles": []}
    for word, rest in _items(body):
        if word == "gain":
            values["gain"] = parse_coefficient(rest, "the gain")
        elif (power := _power(word, variable)) is not None and not rest:
            values["s_power"] = power
        elif word in ("zeros", "poles"):
            values[word] = _factors(rest, variable)
        else:
            raise FormError(
                f"factored: {word!r}: write gain G; {variable}^N; zeros F F ...; poles F F ... "
                f"with factors ({variable}+a), (1+T{variable}), sos(zeta, omega)"
            )
    return FactoredBlock(**values)


def _factors(text: str, x: str) -> list[FactorModel]:
    """Factors '(x+a)', '(x-a)', '(1+Tx)' or '(1+T*x)', 'sos(zeta, omega)', side by side."""
    v = re.escape(x)
    patterns = [
        (rf"\(\s*{v}\s*([-+])\s*({COEF})\s*\)", "root"),
        (rf"\(\s*1\s*\+\s*({COEF})\s*\*?\s*{v}\s*\)", "time_constant"),
        (rf"sos\(\s*({COEF})\s*,\s*({COEF})\s*\)", "second_order"),
    ]
    factors, rest = [], text.strip()
    while rest:
        for pattern, kind in patterns:
            match = re.match(pattern, rest)
            if match:
                factors.append(_factor(kind, match.groups()))
                rest = rest[match.end() :].strip()
                break
        else:
            raise FormError(f"factored: cannot read {rest[:30]!r}: factors are ({x}+a), (1+T{x}), sos(zeta, omega)")
    return factors


def _factor(kind: str, groups: tuple[str, ...]) -> FactorModel:
    if kind == "root":
        sign, a = groups
        value = parse_coefficient(a, "a root")
        if sign == "-":
            if isinstance(value, str):
                raise FormError(f"factored: ({value} with a minus sign): a parameter root is written (s+{value})")
            value = -value
        return FactorModel(kind="root", a=value)
    if kind == "time_constant":
        return FactorModel(kind="time_constant", T=parse_coefficient(groups[0], "a time constant"))
    return FactorModel(
        kind="second_order", zeta=parse_coefficient(groups[0], "zeta"), omega=parse_coefficient(groups[1], "omega")
    )


def _controller(body: str, variable: str, _current) -> ControllerBlock:
    values: dict = {"kind": "controller", "factors": []}
    for word, rest in _items(body):
        words = rest.split()
        if word == "gain":
            values["gain"] = parse_coefficient(rest, "the gain")
        elif (power := _power(word, variable)) is not None and not rest:
            values["s_power"] = power
        elif word in ("zero", "pole") and len(words) == 1:
            values["factors"].append(ControllerFactorModel(kind=word, b=parse_coefficient(words[0], "a corner")))
        elif word in ("complex_zero", "complex_pole") and len(words) == 2:
            values["factors"].append(
                ControllerFactorModel(
                    kind=word,
                    damping=parse_coefficient(words[0], "a damping"),
                    frequency=parse_coefficient(words[1], "a frequency"),
                )
            )
        else:
            raise FormError(
                f"controller: {word!r}: write gain G; {variable}^N; zero b; pole b; "
                "complex_zero zeta w; complex_pole zeta w"
            )
    if "gain" not in values:
        raise FormError("controller: give its gain (gain G)")
    return ControllerBlock(**values)


def _polynomial(body: str, _variable: str, _current) -> PolynomialBlock:
    values: dict = {"kind": "polynomial", "order": "descending"}
    for word, rest in _items(body):
        if word in ("num", "den"):
            values["numerator" if word == "num" else "denominator"] = [
                parse_coefficient(c, "a coefficient") for c in rest.split(",") if c.strip()
            ]
        elif word in ("ascending", "descending") and not rest:
            values["order"] = word
        else:
            raise FormError(f"polynomial: {word!r}: write num c0, c1, ...; den d0, d1, ...; ascending|descending")
    if "numerator" not in values or "denominator" not in values:
        raise FormError("polynomial: give num ... and den ...")
    return PolynomialBlock(**values)


def _delay(body: str, _variable: str, _current) -> DelayBlock:
    return DelayBlock(kind="delay", tau=parse_coefficient(body, "the delay"))


def _discretized(body: str, _variable: str, _current) -> DiscretizedBlock:
    """'EXPR; zoh|tustin|matched[; delay SECONDS][; prewarp RAD/S]': a continuous block held on the way in."""
    parts = [p.strip() for p in body.split(";")]
    if len(parts) < 2:
        raise FormError("discretized: write EXPR; zoh|tustin|matched[; delay SECONDS][; prewarp RAD/S]")
    options = {}
    for item in parts[2:]:
        name, _, value = item.partition(" ")
        if name not in ("delay", "prewarp"):
            raise FormError(f"discretized: {item!r}: the options are delay SECONDS and prewarp RAD/S")
        options[name] = parse_number(value, f"the {name}")
    return DiscretizedBlock(kind="discretized", expression=parse_expression(parts[0], "s"), method=parts[1], **options)


def _table(body: str, _variable: str, current) -> TableBlock:
    words = body.split()
    inline = bool(words) and words[0] == "inline"
    shape = "inline FORM UNIT gain G" if inline else "FILE columns F,A,B FORM UNIT gain G"
    if len(words) != (5 if inline else 7) or words[-2] != "gain" or (not inline and words[1] != "columns"):
        raise FormError(f"table: write {shape}")
    form, unit = words[-4], words[-3]
    table = {"form": form, "unit": unit, "gain": parse_number(words[-1], "a gain")}
    if inline:
        if current is None or getattr(current, "kind", None) != "table" or current.table.csv is not None:
            raise FormError("table: an inline table keeps its data: write a CSV file's name to read one")
        old = current.table
        table.update(frequency=old.frequency, first=old.first, second=old.second)
    else:
        table.update(csv=words[0], columns=[c.strip() for c in words[2].split(",")])
    return TableBlock.model_validate({"kind": "table", "table": table})


def _state_space(body: str, _variable: str, current) -> StateSpaceBlock:
    name = body.strip()
    if not name:
        raise FormError("state_space: write a .npz or .json file's name (beside the session), or inline")
    if name != "inline":
        return StateSpaceBlock(kind="state_space", file=name)
    if current is None or getattr(current, "kind", None) != "state_space" or current.file is not None:
        raise FormError("state_space: an inline state space keeps its matrices: write a file's name to read one")
    return current.model_copy()


def format_sub_compensator(sub) -> str:
    """A channel's sub-compensator: 'num x0, x1, ...; den y0, y1, ...' (ascending powers)."""
    c = format_coefficient
    return f"num {', '.join(map(c, sub.numerator))}; den {', '.join(map(c, sub.denominator))}"


def parse_sub_compensator(text: str):
    """A channel's sub-compensator from 'num x0, x1, ...; den y0, y1, ...' (ascending powers)."""
    from sessions.format.schema import SubCompensatorModel

    block = _polynomial(text, "s", None)
    try:
        return SubCompensatorModel(numerator=block.numerator, denominator=block.denominator)
    except ValidationError as exc:
        raise FormError(f"compensator: {invalid_what(exc)}") from None


def quote_name(name: str) -> str:
    """A block's or signal's name as one word: in double quotes when it has spaces."""
    return f'"{name}"' if not name or any(ch.isspace() for ch in name) else name


def split_names(text: str, count: int) -> tuple[list[str], str]:
    """``count`` leading names (bare words or "quoted names") and the rest of the text."""
    names, rest = [], text.strip()
    for _ in range(count):
        match = re.match(r'"([^"]+)"\s*|(\S+)\s*', rest)
        if not match:
            break
        names.append(match.group(1) if match.group(1) is not None else match.group(2))
        rest = rest[match.end() :]
    return names, rest.strip()


def transfer_names(t, variable: str) -> set[str]:
    """The parameter names a transfer model reads."""
    if t.kind == "expression":
        from engine.model.expressions import Expression

        return set(Expression(t.expression, variable).parameters)
    if t.kind in ("table", "state_space", "discretized"):
        return set()
    names: set[str] = set()

    def collect(node) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                if key not in ("kind", "order"):
                    collect(value)
        elif isinstance(node, list):
            for item in node:
                collect(item)
        elif isinstance(node, str):
            names.add(node)

    collect(t.model_dump())
    return names

"""The one-line text forms of the workbench's edit dialogs: ``parse_X(text)`` reads
what was typed (or raises `FormError` saying what is expected), ``format_X(value)``
writes text that reads back exactly (short ``:g`` numbers where exact, else repr)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal, NamedTuple

from engine.errors import EngineError
from engine.model.expressions import Expression
from sessions.format.checks import invalid
from sessions.format.schema import BandModel, PointModel, ResponseModel, SegmentModel

Sense = Literal["at_least", "at_most"] | None
Setting = bool | int | float | str | None
BAND_FORM = "LOW..HIGH: DESIRED [/ REQUIRED]"
POINT_FORM = "push|pull REAL+IMAGj, e.g. push -1+0j"
RESPONSE_CLAUSES = dict(
    step="step T A", ramp="ramp T S", psd="psd F(s)", reference="reference R", settling="settling B"
)


class FormError(ValueError):
    """Text that does not read as the form it was typed into; the message says what is expected."""


class ParameterLine(NamedTuple):
    """'NAME VALUE [MIN MAX]': a new shared parameter."""

    name: str
    value: float
    min: float | None
    max: float | None


class BlockLine(NamedTuple):
    """'NAME INPUT OUTPUT EXPRESSION': a new diagram block."""

    name: str
    input: str
    output: str
    expression: str


class EntryLine(NamedTuple):
    """'ROW COL EXPRESSION': a new matrix-format entry (rows and columns from 1)."""

    row: int
    col: int
    expression: str


def parse_number(text: str, what: str = "a number") -> float:
    """A number (not nan), e.g. a target's weight or scale; a FormError names ``what`` was expected."""
    try:
        value = float(text)
    except ValueError:
        raise FormError(f"expected {what}, got {text.strip()!r}") from None
    if math.isnan(value):
        raise FormError(f"expected {what}, got nan")
    return value


def parse_sample_time(text: str) -> float:
    """A sample time: a finite number of seconds > 0."""
    value = parse_number(text, "the sample time (s)")
    if not (math.isfinite(value) and value > 0):
        raise FormError(f"{text.strip()!r}: a sample time is a finite number of seconds > 0")
    return value


def format_number(value: float) -> str:
    """A number exactly: its short ':g' text where that reads back exactly, else its repr."""
    text = f"{value:g}"
    return text if float(text) == value else repr(float(value))


def _model(cls, **values):
    """A schema model, its validation error turned into a FormError."""
    try:
        return cls(**values)
    except ValueError as exc:  # pydantic's ValidationError is one
        raise FormError(invalid(exc, top="")) from None


def parse_expression(text: str, variable: str | None, what: str = "expression") -> str:
    """An expression: the stripped text, checked in ``variable`` when one is given."""
    text = text.strip()
    if not text:
        raise FormError(f"expected an {what}")
    if variable is not None:
        try:
            Expression(text, variable)
        except EngineError as exc:
            raise FormError(f"{what}: {exc}") from None
    return text


def _parts(text: str) -> list[str]:
    """The non-empty ';'-separated parts of a text, stripped."""
    return [p.strip() for p in text.split(";") if p.strip()]


def parse_optional(text: str) -> float | None:
    """A number, or None for '', 'none' or any infinity ('inf', '1e999': no bound)."""
    if text.strip().lower() in ("", "none", "inf"):
        return None
    value = parse_number(text, "a number, or none")
    return None if math.isinf(value) else value


def format_optional(value: float | None) -> str:
    """'none' for None, else the number."""
    return "none" if value is None else format_number(value)


def parse_signed(text: str) -> tuple[list[str], list[str]]:
    """'+r -y': a junction's (plus, minus) input signals."""
    signed: dict[str, list[str]] = {"+": [], "-": []}
    for word in text.split():
        if word[0] not in "+-" or len(word) < 2:
            raise FormError(f"{word!r}: write +SIGNAL or -SIGNAL")
        signed[word[0]].append(word[1:])
    if not signed["+"] and not signed["-"]:
        raise FormError("expected at least one signal: +SIGNAL or -SIGNAL")
    return signed["+"], signed["-"]


def format_signed(value: tuple[Sequence[str], Sequence[str]]) -> str:
    """A junction's (plus, minus) signals as '+a +b -c'."""
    plus, minus = value
    return " ".join([f"+{x}" for x in plus] + [f"-{x}" for x in minus])


def parse_values(text: str, old: float | list[float]) -> float | list[float]:
    """One number, or for a per-condition value (``old`` a list) one for all or one per condition."""
    values = [parse_number(w) for w in text.replace(",", " ").split()]
    if not isinstance(old, list):
        if len(values) != 1:
            raise FormError("expected one number")
        return values[0]
    if len(values) == 1:
        return values * len(old)
    if len(values) != len(old):
        raise FormError(f"expected one number, or {len(old)} (one per condition)")
    return values


def format_values(value: float | list[float]) -> str:
    """One number, or a per-condition list as 'a, b, c'."""
    return ", ".join(format_number(v) for v in value) if isinstance(value, list) else format_number(value)


def parse_parameter(text: str) -> ParameterLine:
    """'NAME VALUE [MIN MAX]' (a bound none or +-inf: unbounded)."""
    words = text.split()
    if len(words) not in (2, 4) or not words[0].isidentifier():
        raise FormError("write NAME VALUE, or NAME VALUE MIN MAX (NAME an identifier)")
    bounds = [None if w.lower() == "none" else parse_number(w, "a bound (a number or none)") for w in words[2:]]
    low, high = [None if b is None or math.isinf(b) else b for b in bounds] or [None, None]
    if low is not None and high is not None and low > high:
        raise FormError(f"MIN {format_number(low)} must not exceed MAX {format_number(high)}")
    return ParameterLine(words[0], parse_number(words[1], "a number for VALUE"), low, high)


def format_parameter(line: tuple[str, float, float | None, float | None]) -> str:
    """'NAME VALUE', with 'MIN MAX' when either bound is set."""
    name, value, low, high = line
    bounds = "" if low is None and high is None else f" {format_optional(low)} {format_optional(high)}"
    return f"{name} {format_number(value)}{bounds}"


def parse_block(text: str, variable: str | None = None) -> BlockLine:
    """'NAME INPUT OUTPUT EXPRESSION' (the expression checked in ``variable`` if given)."""
    words = text.split(None, 3)
    if len(words) != 4:
        raise FormError("write NAME INPUT OUTPUT EXPRESSION")
    return BlockLine(words[0], words[1], words[2], parse_expression(words[3], variable))


def format_block(line: tuple[str, str, str, str]) -> str:
    """A block as 'NAME INPUT OUTPUT EXPRESSION'."""
    return " ".join(line)


def parse_matrix_entry(text: str, variable: str | None = None) -> EntryLine:
    """'ROW COL EXPRESSION', rows and columns from 1 (the expression checked in ``variable`` if given)."""
    words = text.split(None, 2)
    if len(words) != 3 or not (words[0].isdecimal() and words[1].isdecimal()):
        raise FormError("write ROW COL EXPRESSION (rows and columns from 1)")
    row, col = int(words[0]), int(words[1])
    if row < 1 or col < 1:
        raise FormError(f"rows and columns count from 1, got {row} {col}")
    return EntryLine(row, col, parse_expression(words[2], variable))


def format_matrix_entry(line: tuple[int, int, str]) -> str:
    """A matrix entry as 'ROW COL EXPRESSION'."""
    row, col, expression = line
    return f"{row} {col} {expression}"


def parse_range(text: str) -> tuple[float, float | None]:
    """'LOW..HIGH' frequencies, HIGH inf (or any +inf) meaning no limit: (low, high or None)."""
    low_text, dots, high_text = text.partition("..")
    if not dots:
        raise FormError(f"expected LOW..HIGH (HIGH inf: no limit), got {text.strip()!r}")
    low = parse_number(low_text, "a number for LOW")
    if not high_text.strip():
        raise FormError("expected a number or inf for HIGH after '..'")
    high = parse_number(high_text, "a number or inf for HIGH")
    if low < 0:
        raise FormError(f"LOW must be >= 0, got {format_number(low)}")
    if high < low:
        raise FormError(f"HIGH {format_number(high)} must not be below LOW {format_number(low)}")
    return low, None if high == math.inf else high


def format_range(value: tuple[float, float | None]) -> str:
    """(low, high) as 'LOW..HIGH', high None as 'inf'."""
    low, high = value
    return f"{format_number(low)}..{'inf' if high is None else format_number(high)}"


def _parse_band(part: str) -> BandModel:
    """One 'LOW..HIGH: DESIRED [/ REQUIRED]'; 'DESIRED [/ REQUIRED]' alone: every frequency."""
    span, colon, values = part.partition(":")
    if not colon:
        span, values = "0..inf", part
    desired, _, required = values.partition("/")
    try:
        low, high = parse_range(span)
        return _model(
            BandModel,
            low=low,
            high=high,
            desired=parse_number(desired, "a number for DESIRED"),
            required=parse_number(required, "a number for REQUIRED") if required.strip() else None,
        )
    except FormError as exc:
        hint = "" if colon else f" (write {BAND_FORM}, or DESIRED alone for every frequency)"
        raise FormError(f"band {part!r}: {exc}{hint}") from None


def parse_bands(text: str) -> list[BandModel]:
    """'LOW..HIGH: DESIRED [/ REQUIRED]; ...' (at least one band)."""
    bands = [_parse_band(part) for part in _parts(text)]
    if not bands:
        raise FormError(f"expected at least one band: {BAND_FORM}")
    return bands


def format_bands(bands: Sequence[BandModel]) -> str:
    """Bands as 'low..high: desired', '/ required' where a requirement is set."""
    return "; ".join(
        f"{format_range((b.low, b.high))}: {format_number(b.desired)}"
        + ("" if b.required is None else f" / {format_number(b.required)}")
        for b in bands
    )


def _parse_point(part: str) -> PointModel:
    """One 'push|pull COMPLEX'."""
    words = part.split(None, 1)
    if len(words) != 2:
        raise FormError(f"{part!r}: write {POINT_FORM}")
    mode, value = words
    if mode not in ("push", "pull"):
        raise FormError(f"{mode!r}: push or pull ({POINT_FORM})")
    try:
        point = complex(value.replace(" ", ""))
    except ValueError:
        raise FormError(f"{value!r}: expected a complex number such as -1+0j or -7-3j") from None
    if math.isnan(point.real) or math.isnan(point.imag):
        raise FormError(f"{value!r}: expected a complex number, not nan")
    return _model(PointModel, real=point.real, imag=point.imag, mode=mode)


def parse_points(text: str) -> list[PointModel]:
    """'push -1+0j; pull -7-3j' (empty: no points, the defaults)."""
    return [_parse_point(part) for part in _parts(text)]


def format_points(points: Sequence[PointModel]) -> str:
    """Points as 'push -1+0j; pull -7-3j'."""
    return "; ".join(f"{p.mode} {repr(complex(p.real, p.imag)).strip('()')}" for p in points)


def parse_sense(text: str) -> Sense:
    """'at_least', 'at_most', or 'auto' (None: the measure's own)."""
    text = text.strip()
    if text not in ("at_least", "at_most", "auto"):
        raise FormError(f"expected at_least, at_most or auto, got {text!r}")
    return None if text == "auto" else text  # type: ignore[return-value]


def format_sense(value: Sense) -> str:
    """A sense, None as 'auto'."""
    return value or "auto"


def parse_bool(text: str) -> bool:
    """'true' or 'false' (any case)."""
    word = text.strip().lower()
    if word not in ("true", "false"):
        raise FormError(f"expected true or false, got {text.strip()!r}")
    return word == "true"


def format_bool(value: bool) -> str:
    """'true' or 'false'."""
    return "true" if value else "false"


def _response_head(part: str) -> dict:
    """The fields of 'INPUT OUTPUT HORIZON [POINTS]'."""
    head = part.split()
    if len(head) not in (3, 4):
        raise FormError(f"begin with INPUT OUTPUT HORIZON [POINTS], got {part!r}")
    values: dict = {"input": head[0], "output": head[1], "horizon": parse_number(head[2], "a number for HORIZON")}
    if len(head) == 4:
        if not head[3].isdecimal():
            raise FormError(f"expected a whole number for POINTS, got {head[3]!r}")
        values["points"] = int(head[3])
    return values


def _response_clause(part: str, values: dict) -> None:
    """Apply one 'step T A', 'ramp T S', 'psd F(s)', 'reference R' or 'settling B' to ``values``."""
    word, rest = (part.split(None, 1) + [""])[:2]
    if word not in RESPONSE_CLAUSES:
        raise FormError(f"{word!r}: expected one of {'; '.join(RESPONSE_CLAUSES.values())}")
    if word == "psd":
        values["psd"] = parse_expression(rest, "s", "psd shaping filter F(s)")
        return
    numbers = rest.split()
    if len(numbers) != (2 if word in ("step", "ramp") else 1):
        raise FormError(f"{part!r}: write {RESPONSE_CLAUSES[word]}")
    amounts = [parse_number(n, f"a number in {RESPONSE_CLAUSES[word]!r}") for n in numbers]
    if word in ("step", "ramp"):
        field = "step" if word == "step" else "slope"
        values["profile"].append(_model(SegmentModel, time=amounts[0], **{field: amounts[1]}))
    else:
        values["reference" if word == "reference" else "settling_band"] = amounts[0]


def parse_response(text: str) -> ResponseModel | None:
    """'INPUT OUTPUT HORIZON [POINTS]; step T A; ramp T S; psd F(s); reference R; settling B' (empty: none)."""
    parts = _parts(text)
    if not parts:
        return None
    values = _response_head(parts[0]) | {"profile": []}
    for part in parts[1:]:
        _response_clause(part, values)
    values["profile"] = values["profile"] or [SegmentModel(step=1.0)]
    return _model(ResponseModel, **values)


def format_response(response: ResponseModel | None) -> str:
    """A time response as one line (see `parse_response`); None as ''."""
    if response is None:
        return ""
    parts = [f"{response.input} {response.output} {format_number(response.horizon)} {response.points}"]
    for seg in response.profile:
        if seg.step or not seg.slope:
            parts.append(f"step {format_number(seg.time)} {format_number(seg.step)}")
        if seg.slope:
            parts.append(f"ramp {format_number(seg.time)} {format_number(seg.slope)}")
    if response.psd:
        parts.append(f"psd {response.psd}")
    if response.reference != 1.0:
        parts.append(f"reference {format_number(response.reference)}")
    if response.settling_band != ResponseModel.model_fields["settling_band"].default:
        parts.append(f"settling {format_number(response.settling_band)}")
    return "; ".join(parts)


def _setting_number(text: str, current: int | float) -> int | float:
    """A number setting: an integer where the setting is one and the number is whole."""
    if isinstance(current, int) and (text.isdecimal() or (text[1:].isdecimal() and text[0] in "+-")):
        return int(text)
    number = parse_number(text, "a number, or none")
    return int(number) if isinstance(current, int) and number.is_integer() else number


def parse_setting(text: str, current: Setting) -> Setting:
    """A setting of the type of ``current``: true/false, a number, text; '' or 'none' unsets it."""
    text = text.strip()
    if isinstance(current, bool):
        return parse_bool(text)
    if text.lower() in ("", "none"):
        return None
    if isinstance(current, (int, float)):
        return _setting_number(text, current)
    if isinstance(current, str):
        return text
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    try:
        return parse_number(text)
    except FormError:
        return text


def format_setting(value: Setting) -> str:
    """A setting's text: true/false, repr of a number, the text itself; None as 'none'."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return format_bool(value)
    return repr(value) if isinstance(value, float) else str(value)

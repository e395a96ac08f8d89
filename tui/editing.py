"""Edits of the session model from the workbench's tables: what can be
edited in a row, how the new text is checked as it is typed, and how it is
applied (the problem is rebuilt; on error the old value comes back)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from engine.algorithm import make_settings
from engine.errors import EngineError
from engine.expressions import Expression
from sessions.errors import SessionError

from .workbench import Workbench


@dataclass(frozen=True)
class Edit:
    """One editable value: its title, current text, checker and setter."""

    title: str
    text: str
    check: Callable[[str], str | None]
    apply: Callable[[str], None]


def number_check(text: str) -> str | None:
    try:
        value = float(text)
    except ValueError:
        return f"not a number: {text!r}"
    return None if value == value else "not a number"


def optional_number_check(text: str) -> str | None:
    return None if text.strip().lower() in ("", "none", "inf") else number_check(text)


def expression_check(variable: str) -> Callable[[str], str | None]:
    def check(text: str) -> str | None:
        try:
            Expression(text, variable)
        except EngineError as exc:
            return str(exc)
        return None
    return check


def set_fields(bench: Workbench, owner: object, **values: object) -> None:
    """Set fields of a model object and rebuild the problem; if it no longer
    builds, put the old values back and raise the reason (nothing is lost)."""
    old = {name: getattr(owner, name) for name in values}
    for name, value in values.items():
        setattr(owner, name, value)
    try:
        bench.rebuild()
    except (SessionError, EngineError) as exc:
        for name, value in old.items():
            setattr(owner, name, value)
        bench.rebuild()
        raise SessionError(str(exc)) from None


def _expression_slots(bench: Workbench) -> list[tuple[str, object, str, str] | None]:
    """Per row of the plant table: (title, model object, attribute, variable) of an editable
    expression, or None (tables, junctions, ...).  The rows follow `screens.main.plant_rows`."""
    from .screens.main import plant_rows
    slots: list = []
    for condition in bench.session.model.problem.conditions:
        plant = condition.plant
        rows = plant_rows(condition)
        if plant.format == "diagram":
            for block in plant.blocks:
                editable = block.transfer.kind == "expression"
                slots.append((f"{condition.name}: {block.name}", block.transfer, "expression", condition.variable)
                             if editable else None)
            slots += [None] * (len(rows) - len(plant.blocks))
        elif plant.format == "matrix":
            slots += [(f"{condition.name}: a[{e.row},{e.col}]", e, "expression", condition.variable)
                      for e in plant.entries]
        else:
            slots += [None] * len(rows)
    return slots


def block_edit(bench: Workbench, row: int) -> Edit | None:
    """The expression of a diagram block or of a matrix-format entry."""
    slots = _expression_slots(bench)
    if not 0 <= row < len(slots) or slots[row] is None:
        return None
    title, owner, attribute, variable = slots[row]

    def setter(text: str) -> None:
        set_fields(bench, owner, **{attribute: text})
    return Edit(f"{title} (expression in {variable})", getattr(owner, attribute), expression_check(variable), setter)


PARAMETER_FIELDS = [("value", "value (every condition when per condition)"), ("min", "lower bound (none: unbounded)"),
                    ("max", "upper bound (none: unbounded)")]


def parameter_edit(bench: Workbench, row: int, field: str = "value") -> Edit | None:
    params = bench.session.model.problem.parameters
    if not 0 <= row < len(params):
        return None
    p = params[row]
    if field == "value":
        current = p.value[0] if isinstance(p.value, list) else p.value
        check = number_check
    else:
        current = getattr(p, field)
        check = optional_number_check

    def setter(text: str) -> None:
        old = getattr(p, field)
        if field == "value":
            value = [float(text)] * len(old) if isinstance(old, list) else float(text)
        else:
            value = None if text.strip().lower() in ("", "none", "inf") else float(text)
        set_fields(bench, p, **{field: value})
    return Edit(f"parameter {p.name}: {field}", "none" if current is None else repr(current), check, setter)


def toggle_free(bench: Workbench, row: int) -> None:
    params = bench.session.model.problem.parameters
    if 0 <= row < len(params):
        set_fields(bench, params[row], free=not params[row].free)


TARGET_FIELDS = [("bands", "bands: low..high: desired / required (optional); ... (high inf: no limit)"),
                 ("points", "push/pull points: push -1+0j; pull -7-3j (empty: the defaults)"),
                 ("weight", "weight (the c vector component)"),
                 ("detect", "detection range: low..high (inf: no limit)")]


def bands_text(target) -> str:
    """'low..high: desired' per band, '/ required' where a requirement differs from it."""
    return "; ".join(f"{b.low:g}..{'inf' if b.high is None else f'{b.high:g}'}: {b.desired:g}"
                     + ("" if b.required is None else f" / {b.required:g}") for b in target.bands)


def _parse_range(text: str) -> tuple[float, float | None]:
    low, high = text.split("..")
    high = high.strip()
    return float(low), None if high.lower() in ("inf", "") else float(high)


def _parse_bands(text: str) -> list[tuple[float, float | None, float, float | None]]:
    bands = []
    for part in filter(None, (p.strip() for p in text.split(";"))):
        span, values = part.split(":")
        desired, _, required = values.partition("/")
        low, high = _parse_range(span)
        bands.append((low, high, float(desired), float(required) if required.strip() else None))
    if not bands:
        raise ValueError("at least one band")
    return bands


def _parse_points(text: str) -> list[tuple[str, complex]]:
    points = []
    for part in filter(None, (p.strip() for p in text.split(";"))):
        mode, value = part.split(None, 1)
        if mode not in ("push", "pull"):
            raise ValueError(f"{mode!r}: push or pull")
        points.append((mode, complex(value.replace(" ", ""))))
    return points


def _checker(parse: Callable[[str], object]) -> Callable[[str], str | None]:
    def check(text: str) -> str | None:
        try:
            parse(text)
        except (ValueError, TypeError) as exc:
            return f"cannot read {text!r}: {exc}"
        return None
    return check


def target_edit(bench: Workbench, row: int, field: str = "bands") -> Edit | None:
    """A target's bands, points, weight or detection range, as one line of text."""
    targets = bench.session.model.problem.targets
    if not 0 <= row < len(targets):
        return None
    target = targets[row]
    from sessions.schema import BandModel, PointModel
    if field == "bands":
        text, parse = bands_text(target), _parse_bands

        def fields(value):
            return {"bands": [BandModel(low=lo, high=hi, desired=d, required=r) for lo, hi, d, r in value]}
    elif field == "points":
        text = "; ".join(f"{p.mode} {complex(p.real, p.imag)}" for p in target.points)
        parse = _parse_points

        def fields(value):
            return {"points": [PointModel(real=v.real, imag=v.imag, mode=m) for m, v in value]}
    elif field == "weight":
        text, parse = repr(target.weight), float

        def fields(value):
            return {"weight": value}
    else:
        text = f"{target.detect_low:g}..{'inf' if target.detect_high is None else f'{target.detect_high:g}'}"
        parse = _parse_range

        def fields(value):
            return {"detect_low": value[0], "detect_high": value[1]}

    def setter(new_text: str) -> None:
        set_fields(bench, target, **fields(parse(new_text)))
    return Edit(f"{target.measure}: {field} ({target.unit})", text, _checker(parse), setter)


def _setting_value(text: str, current):
    """A setting from text: true/false, a number (an integer where the setting is one), or the text."""
    if isinstance(current, bool) or text in ("true", "false"):
        return text == "true"
    try:
        number = float(text)
    except ValueError:
        return text
    return int(number) if isinstance(current, int) and number.is_integer() else number


def setting_edit(bench: Workbench, name: str) -> Edit:
    """An algorithm setting, checked against the algorithm's own settings as it is typed."""
    settings = bench.session.model.algorithm.settings
    current = settings.get(name)

    def check(text: str) -> str | None:
        try:
            make_settings(bench.algorithm_name, dict(settings, **{name: _setting_value(text, current)}))
        except (EngineError, TypeError) as exc:
            return str(exc)
        return None

    def setter(text: str) -> None:
        settings[name] = _setting_value(text, current)
        bench.reset()
    return Edit(f"{bench.algorithm_name} setting {name}", "" if current is None else str(current), check, setter)


def _diagram_block(bench: Workbench, row: int):
    """The diagram block (and its condition) on a row of the plant table, or None."""
    from .screens.main import plant_rows
    k = 0
    for condition in bench.session.model.problem.conditions:
        rows = plant_rows(condition)
        if condition.plant.format == "diagram" and k <= row < k + len(condition.plant.blocks):
            return condition.plant.blocks[row - k]
        k += len(rows)
    return None


def csv_preview(path: Path, lines: int = 8) -> tuple[list[str], str]:
    """The header's column names and the first lines of a CSV file (comment lines skipped)."""
    text = [line.rstrip("\n") for line in path.read_text(encoding="utf-8", errors="replace").splitlines()
            if not line.startswith("#")]
    if not text:
        raise ValueError(f"{path.name} has no rows")
    return [c.strip() for c in text[0].split(",")], "\n".join(text[:lines])


def table_import(bench: Workbench, row: int, path: Path) -> Edit | None:
    """Make the selected block a table read from a CSV file: the edit line names the
    columns (frequency, first, second), the form, the unit and the gain."""
    block = _diagram_block(bench, row)
    if block is None:
        return None
    header, preview = csv_preview(path)
    folder = bench.session.path.parent if bench.session.path else Path.cwd()
    try:
        name = path.resolve().relative_to(folder.resolve()).as_posix()
    except ValueError:
        name = str(path.resolve())

    def parse(text: str) -> dict:
        words = text.split()
        if len(words) != 4:
            raise ValueError("write: columns form unit gain, e.g. 'hz,mag,deg polar hz 1'")
        columns = [c.strip() for c in words[0].split(",")]
        missing = [c for c in columns if c not in header]
        if missing:
            raise ValueError(f"no column {missing[0]!r}; columns are {', '.join(header)}")
        form, unit = words[1], words[2]
        if form not in ("polar", "cartesian", "magnitude") or unit not in ("hz", "rad/s"):
            raise ValueError("form is polar, cartesian or magnitude; unit hz or rad/s")
        if len(columns) != (2 if form == "magnitude" else 3):
            raise ValueError("three columns (two for magnitude)")
        return {"kind": "table", "table": {"csv": name, "columns": columns, "form": form, "unit": unit,
                                           "gain": float(words[3])}}

    def setter(text: str) -> None:
        from sessions.schema import TableBlock
        set_fields(bench, block, transfer=TableBlock.model_validate(parse(text)))
    guess = f"{','.join(header[:3])} polar hz 1"
    return Edit(f"{block.name} <- {path.name}\n{preview}\n\ncolumns (frequency,first,second) form unit gain:",
                guess, _checker(parse), setter)

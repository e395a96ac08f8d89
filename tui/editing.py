"""Edits of the session model from the workbench's tables: what can be
edited in a row, how the new text is checked as it is typed, and how it is
applied (the problem is rebuilt; on error the old value comes back)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from engine.algorithm import lookup, make_settings
from engine.errors import EngineError
from engine.problem import TIME_MEASURES as _TIME_MEASURES
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
    """The expression of a diagram block or of a matrix-format entry, a junction's
    signed inputs, or where the loop is broken."""
    slots = _expression_slots(bench)
    if not 0 <= row < len(slots):
        return None
    if slots[row] is None:
        return _wiring_edit(bench, row)
    title, owner, attribute, variable = slots[row]

    def setter(text: str) -> None:
        set_fields(bench, owner, **{attribute: text})
    return Edit(f"{title} (expression in {variable})", getattr(owner, attribute), expression_check(variable), setter)


def _wiring_edit(bench: Workbench, row: int) -> Edit | None:
    """A junction's inputs ('+r -y') or a condition's break point, on a plant-table row."""
    condition, offset = _row_owner(bench, row)
    if condition is None or condition.plant.format != "diagram":
        return None
    offset -= len(condition.plant.blocks)
    junctions = condition.plant.junctions
    if 0 <= offset < len(junctions):
        junction = junctions[offset]

        def setter(text: str) -> None:
            plus, minus = _parse_signed(text)
            set_fields(bench, junction, plus=plus, minus=minus)
        text = " ".join([f"+{x}" for x in junction.plus] + [f"-{x}" for x in junction.minus])
        return Edit(f"{condition.name}: junction {junction.name} -> {junction.output} (+a -b ...)", text,
                    _checker(_parse_signed), setter)
    if offset == len(junctions):
        return Edit(f"{condition.name}: break the loop at signal", condition.break_at,
                    lambda text: None if text.strip() else "a signal name",
                    lambda text: set_fields(bench, condition, break_at=text.strip()))
    return None


def _parse_signed(text: str) -> tuple[list[str], list[str]]:
    plus, minus = [], []
    for word in text.split():
        if word[0] not in "+-" or len(word) < 2:
            raise ValueError(f"{word!r}: write +signal or -signal")
        (plus if word[0] == "+" else minus).append(word[1:])
    if not plus and not minus:
        raise ValueError("at least one signal")
    return plus, minus


PARAMETER_FIELDS = [("value", "value (per condition: one for all, or one each: 1, 2, 3)"), ("min", "lower bound (none: unbounded)"),
                    ("max", "upper bound (none: unbounded)")]


def parameter_edit(bench: Workbench, row: int, field: str = "value") -> Edit | None:
    params = bench.session.model.problem.parameters
    if not 0 <= row < len(params):
        return None
    p = params[row]
    if field == "value":
        current = ", ".join(repr(v) for v in p.value) if isinstance(p.value, list) else p.value
        check = _checker(lambda text: _parse_values(text, p.value))
    else:
        current = getattr(p, field)
        check = optional_number_check

    def setter(text: str) -> None:
        old = getattr(p, field)
        if field == "value":
            value = _parse_values(text, old)
        else:
            value = None if text.strip().lower() in ("", "none", "inf") else float(text)
        set_fields(bench, p, **{field: value})
    return Edit(f"parameter {p.name}: {field}", "none" if current is None else repr(current), check, setter)


def _parse_values(text: str, old):
    """One number, or for a per-condition parameter one per condition (one number: all)."""
    values = [float(v) for v in text.replace(",", " ").split()]
    if not isinstance(old, list):
        if len(values) != 1:
            raise ValueError("one number")
        return values[0]
    if len(values) == 1:
        return values * len(old)
    if len(values) != len(old):
        raise ValueError(f"one number, or {len(old)} (one per condition)")
    return values


def copy_condition(bench: Workbench, row: int, name: str) -> None:
    """A new flight condition copied from the one on a plant-table row; parameters
    with a value per condition get the copied condition's value."""
    conditions = bench.session.model.problem.conditions
    source = _condition_at(bench, row)
    if source is None:
        raise SessionError("no condition to copy")
    if not name.strip() or name in [c.name for c in conditions]:
        raise SessionError(f"{name!r}: give a new condition name")
    k = conditions.index(source)
    _change_conditions(bench, lambda values: values + [values[k]],
                       lambda items: items.append(source.model_copy(deep=True, update={"name": name})))


def delete_condition(bench: Workbench, row: int) -> str:
    """Remove the condition on a plant-table row (and its per-condition values)."""
    conditions = bench.session.model.problem.conditions
    source = _condition_at(bench, row)
    if source is None or len(conditions) < 2:
        raise SessionError("a session keeps at least one condition")
    k = conditions.index(source)
    _change_conditions(bench, lambda values: values[:k] + values[k + 1:], lambda items: items.pop(k))
    return source.name


def _change_conditions(bench: Workbench, reshape: Callable[[list], list], change: Callable[[list], None]) -> None:
    """Change the list of conditions and every per-condition value list with it;
    on failure both are restored."""
    params = bench.session.model.problem.parameters
    old_values = [p.value for p in params]
    for p in params:
        if isinstance(p.value, list):
            p.value = reshape(p.value)
    try:
        change_list(bench, bench.session.model.problem.conditions, change)
    except SessionError:
        for p, v in zip(params, old_values):
            p.value = v
        raise


def toggle_per_condition(bench: Workbench, row: int) -> None:
    """A shared parameter gets one value per condition (all equal), or a per-condition
    one becomes shared with its first condition's value."""
    params = bench.session.model.problem.parameters
    if not 0 <= row < len(params):
        return
    p = params[row]
    n = len(bench.session.model.problem.conditions)
    set_fields(bench, p, value=p.value[0] if isinstance(p.value, list) else [p.value] * n)


def toggle_free(bench: Workbench, row: int) -> None:
    params = bench.session.model.problem.parameters
    if 0 <= row < len(params):
        set_fields(bench, params[row], free=not params[row].free)


TARGET_FIELDS = [("bands", "bands: low..high: desired / required (optional); ... (high inf: no limit)"),
                 ("points", "push/pull points: push -1+0j; pull -7-3j (empty: the defaults)"),
                 ("weight", "weight (the c vector component; slp: W2)"),
                 ("scale", "scale factor (slp: S, e.g. 0.2 so 5 deg count as 1 dB)"),
                 ("sense", "sense: at_least, at_most or auto (the measure's own)"),
                 ("constraint", "requirement (true) or objective only (false)"),
                 ("response", "time response: INPUT OUTPUT HORIZON [POINTS]; step T A; ramp T S; psd F(s); ..."),
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


def response_text(response) -> str:
    """A time response as one line (see `_parse_response`)."""
    if response is None:
        return ""
    parts = [f"{response.input} {response.output} {response.horizon:g} {response.points}"]
    for seg in response.profile:
        if seg.step:
            parts.append(f"step {seg.time:g} {seg.step:g}")
        if seg.slope:
            parts.append(f"ramp {seg.time:g} {seg.slope:g}")
    if response.psd:
        parts.append(f"psd {response.psd}")
    if response.reference != 1.0:
        parts.append(f"reference {response.reference:g}")
    return "; ".join(parts)


def _parse_response(text: str):
    """'INPUT OUTPUT HORIZON [POINTS]; step T A; ramp T S; psd F(s); reference R' (empty: none)."""
    from sessions.schema import ResponseModel, SegmentModel
    parts = [p.strip() for p in text.split(";") if p.strip()]
    if not parts:
        return None
    head = parts[0].split()
    if len(head) not in (3, 4):
        raise ValueError("begin with INPUT OUTPUT HORIZON [POINTS]")
    values: dict = {"input": head[0], "output": head[1], "horizon": float(head[2]), "profile": []}
    if len(head) == 4:
        values["points"] = int(head[3])
    for part in parts[1:]:
        word, _, rest = part.partition(" ")
        if word in ("step", "ramp"):
            t, amount = (float(v) for v in rest.split())
            values["profile"].append(SegmentModel(time=t, **{"step" if word == "step" else "slope": amount}))
        elif word == "psd":
            Expression(rest, "s")
            values["psd"] = rest.strip()
        elif word == "reference":
            values["reference"] = float(rest)
        else:
            raise ValueError(f"{word!r}: step, ramp, psd or reference")
    values["profile"] = values["profile"] or [SegmentModel(step=1.0)]
    return ResponseModel(**values)


def _parse_sense(text: str) -> str | None:
    text = text.strip()
    if text not in ("at_least", "at_most", "auto"):
        raise ValueError("at_least, at_most or auto")
    return None if text == "auto" else text


def _parse_bool(text: str) -> bool:
    if text.strip().lower() not in ("true", "false"):
        raise ValueError("true or false")
    return text.strip().lower() == "true"


def _checker(parse: Callable[[str], object]) -> Callable[[str], str | None]:
    def check(text: str) -> str | None:
        try:
            parse(text)
        except (ValueError, TypeError, EngineError) as exc:
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
    elif field in ("weight", "scale"):
        text, parse = repr(getattr(target, field)), float

        def fields(value):
            return {field: value}
    elif field == "sense":
        text, parse = target.sense or "auto", _parse_sense

        def fields(value):
            return {"sense": value}
    elif field == "response":
        text, parse = response_text(target.response), _parse_response

        def fields(value):
            return {"response": value}
    elif field == "constraint":
        text, parse = str(target.constraint).lower(), _parse_bool

        def fields(value):
            return {"constraint": value}
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


def setting_rows(bench: Workbench) -> list[tuple[str, object, bool]]:
    """Every setting of the session's algorithm: (name, value, set in the session)."""
    try:
        defaults = {f.name: f.default for f in dataclasses.fields(lookup(bench.algorithm_name).settings)}
    except EngineError:
        defaults = {}
    settings = bench.session.model.algorithm.settings
    names = list(defaults) + [n for n in settings if n not in defaults]
    return [(n, settings.get(n, defaults.get(n)), n in settings) for n in names]


def objective_rows(bench: Workbench) -> list[tuple[str, str, Callable[[], Edit] | None]]:
    """The rows of the objective/settings table: label, value, and how to edit it."""
    objective = bench.session.model.problem.objective
    rows: list = []
    if objective is not None:
        rows.append(("objective kind", objective.kind, None))
        rows += [(name, str(value), (lambda n=name: objective_option_edit(bench, n)))
                 for name, value in objective.options.items()]
    rows += [(f"{bench.algorithm_name}.{name}" + ("" if given else " (default)"), str(value),
              (lambda n=name: setting_edit(bench, n))) for name, value, given in setting_rows(bench)]
    return rows


def objective_option_edit(bench: Workbench, name: str) -> Edit:
    """An objective option (a penalty such as q2, or a text option): a number where it was one."""
    objective = bench.session.model.problem.objective
    current = objective.options[name]

    def setter(text: str) -> None:
        value = float(text) if isinstance(current, float) else text
        set_fields(bench, objective, options=dict(objective.options, **{name: value}))
    check = number_check if isinstance(current, float) else (lambda text: None if text.strip() else "empty")
    return Edit(f"objective option {name}", str(current), check, setter)


def setting_edit(bench: Workbench, name: str) -> Edit:
    """An algorithm setting, checked against the algorithm's own settings as it is typed."""
    settings = bench.session.model.algorithm.settings
    current = settings.get(name, dict((n, v) for n, v, _ in setting_rows(bench)).get(name))

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
    """The diagram block on a row of the plant table, or None."""
    found = _block_position(bench, row)
    return None if found is None else found[0][found[1]]


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


# -- adding and deleting rows ------------------------------------------------

DEFAULT_DESIRED = {"gain_margin": 0.5, "phase_margin": 0.5, "stability_margin": 0.5, "attenuation_margin": 0.25,
                   "gain_margin_db": 6.0, "phase_margin_deg": 30.0, "crossover_frequency": 1.0,
                   "modal_peak_db": -10.0, "modal_peak_phase_deg": 90.0, "stability_abscissa": 0.0,
                   "rise_time": 1.0, "settling_time": 5.0, "overshoot_percent": 20.0, "peak_time": 2.0,
                   "steady_state_error": 0.01, "peak_response": 1.0, "mean_square": 1.0}


def change_list(bench: Workbench, items: list, change: Callable[[list], None]) -> None:
    """Change a list of the model in place and rebuild; on failure restore it (nothing is lost)."""
    old = list(items)
    change(items)
    try:
        bench.rebuild()
    except (SessionError, EngineError) as exc:
        items[:] = old
        bench.rebuild()
        raise SessionError(str(exc)) from None


def add_target(bench: Workbench, measure: str) -> None:
    """A new target of one measure kind with one band (time measures read the first
    input's step response of the last signal; edit them after)."""
    from sessions.schema import BandModel, ResponseModel, TargetModel
    response = None
    if measure in DEFAULT_DESIRED and measure in _TIME_MEASURES:
        network = bench.session.problem.conditions[0].network
        output = next((n for n in ("y", "c", "theta") if n in network.signals), network.signals[-1])
        response = ResponseModel(input=network.inputs[0] if network.inputs else "r", output=output)
    target = TargetModel(measure=measure, bands=[BandModel(desired=DEFAULT_DESIRED.get(measure, 1.0))],
                         response=response)
    change_list(bench, bench.session.model.problem.targets, lambda items: items.append(target))


def delete_row(bench: Workbench, table: str, row: int) -> str | None:
    """Delete a target, a parameter or a diagram block; what was deleted (None: nothing there)."""
    problem = bench.session.model.problem
    if table == "targets-table" and 0 <= row < len(problem.targets):
        name = problem.targets[row].measure
        change_list(bench, problem.targets, lambda items: items.pop(row))
        return f"target {name}"
    if table == "parameters" and 0 <= row < len(problem.parameters):
        name = problem.parameters[row].name
        change_list(bench, problem.parameters, lambda items: items.pop(row))
        return f"parameter {name}"
    if table == "blocks":
        entry = _matrix_entry(bench, row)
        if entry is not None:
            entries, k = entry
            name = f"a[{entries[k].row},{entries[k].col}]"
            change_list(bench, entries, lambda items: items.pop(k))
            return f"matrix entry {name}"
        found = _block_position(bench, row)
        if found is not None:
            blocks, k = found
            name = blocks[k].name
            change_list(bench, blocks, lambda items: items.pop(k))
            return f"block {name}"
    return None


def add_parameter(bench: Workbench, text: str) -> None:
    """'NAME VALUE [MIN MAX]': a new shared parameter."""
    from sessions.schema import ParameterModel
    name, value, low, high = _parameter_words(text)
    parameter = ParameterModel(name=name, value=value, min=low, max=high)
    change_list(bench, bench.session.model.problem.parameters, lambda items: items.append(parameter))


def _parameter_words(text: str) -> tuple[str, float, float | None, float | None]:
    words = text.split()
    if len(words) not in (2, 4) or not words[0].isidentifier():
        raise ValueError("write NAME VALUE, or NAME VALUE MIN MAX")
    bounds = [None if w.lower() in ("none", "inf", "-inf") else float(w) for w in words[2:]] or [None, None]
    return words[0], float(words[1]), bounds[0], bounds[1]


def add_block(bench: Workbench, row: int, text: str) -> None:
    """'NAME INPUT OUTPUT EXPRESSION': a new block in the diagram of the selected row's condition."""
    from sessions.schema import BlockModel, ExpressionBlock
    condition = _condition_at(bench, row)
    if condition is not None and condition.plant.format == "matrix":
        _add_matrix_entry(bench, condition, text)
        return
    name, source, target, expression = _block_words(text)
    if condition is None or condition.plant.format != "diagram":
        raise SessionError("blocks are added to block-diagram plants, entries to matrix plants")
    block = BlockModel(name=name, input=source, output=target,
                       transfer=ExpressionBlock(kind="expression", expression=expression))
    change_list(bench, condition.plant.blocks, lambda items: items.append(block))


def _add_matrix_entry(bench: Workbench, condition, text: str) -> None:
    """'ROW COL EXPRESSION' (from 1): a new entry of a matrix-format plant."""
    from sessions.schema import MatrixEntry
    words = text.split(None, 2)
    if len(words) != 3 or not words[0].isdigit() or not words[1].isdigit():
        raise SessionError("a matrix entry: ROW COL EXPRESSION (rows and columns from 1)")
    entry = MatrixEntry(row=int(words[0]), col=int(words[1]), expression=words[2])
    change_list(bench, condition.plant.entries, lambda items: items.append(entry))


def _matrix_entry(bench: Workbench, row: int):
    """(the matrix plant's entries, index) of an entry row, or None."""
    condition, offset = _row_owner(bench, row)
    if condition is None or condition.plant.format != "matrix":
        return None
    return condition.plant.entries, offset


def _block_words(text: str) -> tuple[str, str, str, str]:
    words = text.split(None, 3)
    if len(words) != 4:
        raise ValueError("write NAME INPUT OUTPUT EXPRESSION")
    return words[0], words[1], words[2], words[3]


def _row_owner(bench: Workbench, row: int):
    """(condition, offset of the row within that condition's rows of the plant table),
    or (None, 0) past the last row (`screens.main.plant_rows` gives the rows)."""
    from .screens.main import plant_rows
    k = 0
    for condition in bench.session.model.problem.conditions:
        n = len(plant_rows(condition))
        if k <= row < k + n:
            return condition, row - k
        k += n
    return None, 0


def _condition_at(bench: Workbench, row: int):
    """The condition of a plant-table row (the last one past the end)."""
    conditions = bench.session.model.problem.conditions
    condition, _ = _row_owner(bench, row)
    return condition if condition is not None else (conditions[-1] if conditions else None)


def _block_position(bench: Workbench, row: int):
    """(the diagram's blocks, index) of a block row, or None."""
    condition, offset = _row_owner(bench, row)
    if condition is None or condition.plant.format != "diagram" or offset >= len(condition.plant.blocks):
        return None
    return condition.plant.blocks, offset


ADD_CHECKS = {"parameters": _checker(_parameter_words),
              "blocks": lambda text: None if len(text.split(None, 2)) == 3 and text.split()[0].isdigit()
              else _checker(_block_words)(text)}

"""Edits of parameters, targets, the objective's options, the algorithm's
settings, and a block made a CSV table (with a preview); every one a
transaction on a model path (`tui.state.edits`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from engine.design.measure_kinds import MEASURE_KINDS
from engine.errors import EngineError
from engine.stepping.registry import make_settings
from sessions.errors import SessionError
from sessions.forms import one_line as forms
from sessions.lifecycle import folder, registration
from tui.state.edits import Check, Edit, Ref, change_list, checker, field_edit, resolve, set_fields
from tui.state.workbench import Workbench

PARAMETER_FIELDS = [
    ("value", "value (per condition: one for all, or one each: 1, 2, 3)"),
    ("min", "lower bound (none: unbounded)"),
    ("max", "upper bound (none: unbounded)"),
]
TARGET_FIELDS = [
    ("bands", "bands: low..high: desired / required (optional); ... (high inf: no limit)"),
    ("points", "push/pull points: push -1+0j; pull -7-3j (empty: the defaults)"),
    ("weight", "weight (the c vector component; slp: W2)"),
    ("scale", "scale factor (slp: S, e.g. 0.2 so 5 deg count as 1 dB)"),
    ("sense", "sense: at_least, at_most or auto (the measure's own)"),
    ("requirement", "requirement (true) or objective only (false)"),
    ("response", "time response: INPUT OUTPUT HORIZON [POINTS]; step T A; ramp T S; psd F(s); ..."),
    ("detect", "detection range: low..high (inf: no limit)"),
]


# -- parameters ------------------------------------------------------------------


def parameter_edit(bench: Workbench, ref: Ref, field: str = "value") -> Edit:
    """A parameter's value (one per condition where it has several), min or max; a value
    outside the bounds is refused as it is typed (the bounds are changed on their own)."""
    p = resolve(bench.session.model.problem, ref)
    title = f"parameter {p.name}: {field}"
    if field == "value":

        def parse(text: str):
            return within_bounds(p.name, forms.parse_values(text, p.value), p.min, p.max)

        return field_edit(bench, ref, "value", title, parse, forms.format_values)

    def parse_bound(text: str) -> float | None:
        bound = forms.parse_optional(text)
        low, high = (bound, p.max) if field == "min" else (p.min, bound)
        if low is not None and high is not None and low > high:
            raise forms.FormError(f"min {forms.format_number(low)} would exceed max {forms.format_number(high)}")
        within_bounds(p.name, p.value, low, high, "the value of")
        return bound

    return field_edit(bench, ref, field, title, parse_bound, forms.format_optional)


def within_bounds(name: str, value, low: float | None, high: float | None, what: str = "") -> float | list[float]:
    """``value`` (or each per-condition value) when inside [low, high], else a FormError naming the bounds."""
    for v in value if isinstance(value, list) else [value]:
        if (low is not None and v < low) or (high is not None and v > high):
            span = (
                f"[{'-inf' if low is None else forms.format_number(low)}, "
                f"{'inf' if high is None else forms.format_number(high)}]"
            )
            raise forms.FormError(
                f"{what + ' ' if what else ''}{name} = {forms.format_number(v)} is outside its "
                f"bounds {span}: change the bounds first"
            )
    return value


def toggle_free(bench: Workbench, ref: Ref) -> None:
    """A free parameter is fixed, a fixed one freed."""
    set_fields(bench, ref, free=not resolve(bench.session.model.problem, ref).free)


def toggle_per_condition(bench: Workbench, ref: Ref) -> None:
    """Shared -> one value per condition (all equal); per condition -> shared (the first's)."""
    p = resolve(bench.session.model.problem, ref)
    n = len(bench.session.model.problem.conditions)
    set_fields(bench, ref, value=p.value[0] if isinstance(p.value, list) else [p.value] * n)


def add_parameter(bench: Workbench, text: str) -> None:
    """'NAME VALUE [MIN MAX]': a new shared parameter."""
    from sessions.format.schema import ParameterModel

    name, value, low, high = forms.parse_parameter(text)
    within_bounds(name, value, low, high)
    parameter = ParameterModel(name=name, value=value, min=low, max=high)
    change_list(bench, ("parameters",), lambda items: items.append(parameter))


ADD_PARAMETER_CHECK = checker(lambda text: within_bounds(*forms.parse_parameter(text)))


# -- targets ------------------------------------------------------------------------


def target_edit(bench: Workbench, ref: Ref, field: str = "bands") -> Edit:
    """One field of a target as one line of text."""
    target = resolve(bench.session.model.problem, ref)
    title = f"{target.measure}: {field} ({target.unit})"
    pairs = {
        "bands": (forms.parse_bands, forms.format_bands),
        "points": (forms.parse_points, forms.format_points),
        "weight": (forms.parse_number, forms.format_number),
        "scale": (forms.parse_number, forms.format_number),
        "sense": (forms.parse_sense, forms.format_sense),
        "requirement": (forms.parse_bool, forms.format_bool),
        "response": (forms.parse_response, forms.format_response),
    }
    if field in pairs:
        parse, format_ = pairs[field]
        return field_edit(bench, ref, field, title, parse, format_)
    text = forms.format_range((target.detect_low, target.detect_high))

    def apply(new: str) -> None:
        low, high = forms.parse_range(new)
        set_fields(bench, ref, detect_low=low, detect_high=high)

    return Edit(title, text, checker(forms.parse_range), apply)


def add_target(bench: Workbench, measure: str) -> None:
    """A new target of one measure kind with one band at its default desired value
    (time measures read the first input's step response of the last signal)."""
    from sessions.format.schema import BandModel, ResponseModel, TargetModel

    kind = MEASURE_KINDS[measure]
    response = None
    if kind.domain == "time":
        if not bench.session.problem.conditions:
            raise SessionError(f"a {measure} target reads a flight condition's response; this problem has none")
        network = bench.session.problem.conditions[0].network
        output = next((n for n in ("y", "c", "theta") if n in network.signals), network.signals[-1])
        response = ResponseModel(input=network.inputs[0] if network.inputs else "r", output=output)
    target = TargetModel(measure=measure, bands=[BandModel(desired=kind.default_desired)], response=response)
    change_list(bench, ("targets",), lambda items: items.append(target))


# -- the objective and the algorithm's settings ---------------------------------------


def setting_rows(bench: Workbench) -> list[tuple[str, object, bool]]:
    """Every setting of the session's algorithm: (name, value, set in the session)."""
    try:
        defaults = {f.name: f.default for f in dataclasses.fields(registration(bench.session).settings)}
    except SessionError:
        defaults = {}
    settings = bench.session.model.algorithm.settings
    names = list(defaults) + [n for n in settings if n not in defaults]
    return [(n, settings.get(n, defaults.get(n)), n in settings) for n in names]


def objective_rows(bench: Workbench) -> list[tuple[str, str, Ref | None]]:
    """The rows of the objective/settings table: label, value, and what editing it changes."""
    objective = bench.session.model.problem.objective
    rows: list[tuple[str, str, Ref | None]] = []
    if objective is not None:
        rows.append(("objective kind", objective.kind, None))
        rows += [(name, shown(value), ("objective", name)) for name, value in objective.options.items()]
    lines = bench.session.model.problem.constraints
    states = bench.constraint_states()
    words = [at.state for at in states] if len(states) == len(lines) else [""] * len(lines)
    rows += [
        (f"constraint {k + 1}", f"{line}  ({word} at the design)" if word else line, ("constraint", k))
        for k, (line, word) in enumerate(zip(lines, words))
    ]
    rows += [
        (f"{bench.algorithm_name}.{name}" + ("" if given else " (default)"), shown(value), ("setting", name))
        for name, value, given in setting_rows(bench)
    ]
    return rows


def shown(value: object) -> str:
    """A setting as the table shows it: 'default' for None, yes/no, numbers exactly."""
    if value is None:
        return "default"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return forms.format_number(value)
    return str(value)


def objective_edit(bench: Workbench, ref: Ref) -> Edit:
    """An objective option (`("objective", NAME)`), a linear constraint (`("constraint", K)`)
    or an algorithm setting (`("setting", NAME)`)."""
    if ref[0] == "constraint":
        return constraint_edit(bench, ref[1])
    return objective_option_edit(bench, ref[1]) if ref[0] == "objective" else setting_edit(bench, ref[1])


def constraint_check(bench: Workbench, index: int | None) -> Check:
    """The live check of a constraint line (linear in the parameters, met at their values)."""
    from sessions.errors import SessionError as Refused
    from sessions.format.constraint_lines import check_constraint_line

    def check(text: str) -> str | None:
        try:
            check_constraint_line(text.strip(), bench.session.model.problem, index)
        except (Refused, ValueError, EngineError) as exc:
            return str(exc)
        return None

    return check


def constraint_edit(bench: Workbench, index: int) -> Edit:
    """A linear inequality between parameters, e.g. T1 >= 4*T2."""
    from tui.state.edits import replace_at

    current = bench.session.model.problem.constraints[index]
    return Edit(
        f"constraint {index + 1}: a1*p1 + a2*p2 ... <= c (or >=), e.g. T1 >= 4*T2",
        current,
        constraint_check(bench, index),
        lambda text: replace_at(bench, ("constraints", index), text.strip()),
    )


def add_constraint(bench: Workbench, text: str) -> None:
    """A new linear constraint at the end of the list."""
    change_list(bench, ("constraints",), lambda items: items.append(text.strip()))


def objective_option_edit(bench: Workbench, name: str) -> Edit:
    """An objective option (a penalty such as q2, or a text option): a number where it was one."""
    current = bench.session.model.problem.objective.options[name]
    number = isinstance(current, float)

    def parse(text: str) -> float | str:
        if number:
            return forms.parse_number(text)
        if not text.strip():
            raise forms.FormError("expected a value")
        return text

    def apply(text: str) -> None:
        options = dict(bench.session.model.problem.objective.options, **{name: parse(text)})
        set_fields(bench, ("objective",), options=options)

    return Edit(f"objective option {name}", str(current), checker(parse), apply)


def setting_edit(bench: Workbench, name: str) -> Edit:
    """An algorithm setting, checked against the algorithm's own settings as it is typed."""
    settings = bench.session.model.algorithm.settings
    current = settings.get(name, {n: v for n, v, _ in setting_rows(bench)}.get(name))

    def check(text: str) -> str | None:
        try:
            make_settings(bench.algorithm_name, dict(settings, **{name: forms.parse_setting(text, current)}))
        except (EngineError, TypeError, ValueError) as exc:
            return str(exc)
        return None

    def apply(text: str) -> None:
        bench.book.replace_settings({**settings, name: forms.parse_setting(text, current)})

    return Edit(f"{bench.algorithm_name} setting {name}", forms.format_setting(current), check, apply)


# -- a block from a CSV table -------------------------------------------------------


def csv_preview(path: Path, lines: int = 8) -> tuple[list[str], str]:
    """The header's column names and the first lines of a CSV file (comment lines skipped);
    only a regular file of a table's size is read (`sessions.build.bounded_text`: a FIFO
    typed as the path must not hang the app)."""
    from sessions.build import bounded_text

    try:
        whole = bounded_text(path, "table")
    except SessionError as exc:
        raise ValueError(str(exc)) from None
    text = [line.rstrip("\n") for line in whole.splitlines() if not line.startswith("#")]
    if not text:
        raise ValueError(f"{path.name} has no rows")
    return [c.strip() for c in text[0].split(",")], "\n".join(text[:lines])


def guessed_table_line(header: list[str], preview: str) -> str:
    """A 'columns form unit gain' line guessed from a CSV file's header and first rows (the
    import dialog's starting text, to check and change): the first three columns; form
    'cartesian' for real/imag names, 'db' for a dB name or a second column with a negative
    value (a magnitude in dB read as linear is refused: its gain margin was 193 dB off), else
    'polar'; unit 'hz' when the first column's name says so."""
    names = [h.lower() for h in header[:3]]
    rows = [line.split(",") for line in preview.splitlines()[1:]]
    second = []
    for row in rows:
        try:
            second.append(float(row[1]))
        except (IndexError, ValueError):
            continue
    if len(names) == 3 and names[1].startswith("re") and names[2].startswith("im"):
        form = "cartesian"
    elif len(names) == 2:
        form = "magnitude"
    elif "db" in names[1] or any(v < 0 for v in second):
        form = "db"
    else:
        form = "polar"
    unit = "hz" if "hz" in names[0] else "rad/s"
    return f"{','.join(header[:3])} {form} {unit} 1"


def table_transfer(text: str, header: list[str], csv_name: str) -> dict:
    """A table block's transfer from 'columns form unit gain' ('hz,mag,deg polar hz 1')
    naming columns of a CSV file with ``header``."""
    words = text.split()
    if len(words) != 4:
        raise forms.FormError("write: columns form unit gain, e.g. 'hz,mag,deg polar hz 1'")
    columns = [c.strip() for c in words[0].split(",")]
    missing = [c for c in columns if c not in header]
    if missing:
        raise forms.FormError(f"no column {missing[0]!r}; columns are {', '.join(header)}")
    form, unit = words[1], words[2]
    if form not in ("polar", "db", "cartesian", "magnitude") or unit not in ("hz", "rad/s"):
        raise forms.FormError("form is polar, db (magnitude in dB), cartesian or magnitude; unit hz or rad/s")
    if len(columns) != (2 if form == "magnitude" else 3):
        raise forms.FormError("three columns (two for magnitude)")
    return {
        "kind": "table",
        "table": {
            "csv": csv_name,
            "columns": columns,
            "form": form,
            "unit": unit,
            "gain": forms.parse_number(words[3], "a gain"),
        },
    }


def table_import(bench: Workbench, ref: Ref, path: Path) -> Edit:
    """Make the block at ``ref`` a table read from a CSV file: the edit line names the
    columns (frequency, first, second), the form, the unit and the gain."""
    block = resolve(bench.session.model.problem, ref)
    header, preview = csv_preview(path)
    try:
        name = path.resolve().relative_to(folder(bench.session).resolve()).as_posix()
    except ValueError:
        name = str(path.resolve())

    def parse(text: str) -> dict:
        return table_transfer(text, header, name)

    def apply(text: str) -> None:
        from sessions.format.schema import TableBlock

        set_fields(bench, ref, transfer=TableBlock.model_validate(parse(text)))

    return Edit(
        f"{block.name} <- {path.name}\n{preview}\n\ncolumns (frequency,first,second) form unit gain "
        "(guessed from the columns and rows above: check the form and the unit):",
        guessed_table_line(header, preview),
        checker(parse),
        apply,
    )

"""Edits of the session model from the workbench's tables: what can be
edited in a row, how the new text is checked as it is typed, and how it is
applied (the problem is rebuilt; on error the old value comes back)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

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


def apply_edit(bench: Workbench, change: Callable[[], Callable[[], None]]) -> None:
    """Make a change to the model and rebuild; if the problem no longer builds,
    undo the change and raise the reason (nothing is lost)."""
    restore = change()
    try:
        bench.rebuild()
    except (SessionError, EngineError) as exc:
        restore()
        bench.rebuild()
        raise SessionError(str(exc)) from None


def block_edit(bench: Workbench, row: int) -> Edit | None:
    """The expression of a diagram block (the only free-text plant field)."""
    model = bench.session.model.problem
    k = 0
    for condition in model.conditions:
        if condition.plant.format != "diagram":
            continue
        for block in condition.plant.blocks:
            if k == row:
                if block.transfer.kind != "expression":
                    return None
                transfer = block.transfer

                def setter(text: str, transfer=transfer) -> None:
                    old = transfer.expression

                    def change():
                        transfer.expression = text
                        return lambda: setattr(transfer, "expression", old)
                    apply_edit(bench, change)
                return Edit(f"{condition.name}: {block.name} = (expression in {condition.variable})",
                            transfer.expression, expression_check(condition.variable), setter)
            k += 1
        k += len(condition.plant.junctions) + 1
    return None


def parameter_edit(bench: Workbench, row: int, field: str = "value") -> Edit | None:
    params = bench.session.model.problem.parameters
    if not 0 <= row < len(params):
        return None
    p = params[row]
    current = p.value[0] if isinstance(p.value, list) else p.value

    def setter(text: str) -> None:
        value = float(text)
        old = p.value

        def change():
            p.value = [value] * len(old) if isinstance(old, list) else value
            return lambda: setattr(p, "value", old)
        apply_edit(bench, change)
    return Edit(f"parameter {p.name}: {field}", repr(current), number_check, setter)


def toggle_free(bench: Workbench, row: int) -> None:
    params = bench.session.model.problem.parameters
    if 0 <= row < len(params):
        p = params[row]

        def change():
            p.free = not p.free
            return lambda: setattr(p, "free", not p.free)
        apply_edit(bench, change)


def target_edit(bench: Workbench, row: int) -> Edit | None:
    """The desired value of a target's first band."""
    targets = bench.session.model.problem.targets
    if not 0 <= row < len(targets) or not targets[row].bands:
        return None
    band = targets[row].bands[0]

    def setter(text: str) -> None:
        value, old = float(text), band.desired

        def change():
            band.desired = value
            return lambda: setattr(band, "desired", old)
        apply_edit(bench, change)
    return Edit(f"{targets[row].measure}: desired value (first band)", repr(band.desired), number_check, setter)


def setting_edit(bench: Workbench, name: str) -> Edit:
    """An algorithm setting (numbers stay numbers, the rest text)."""
    settings = bench.session.model.algorithm.settings
    current = settings.get(name)

    def setter(text: str) -> None:
        try:
            value = float(text) if number_check(text) is None else text
        except ValueError:
            value = text
        if isinstance(current, bool) or text in ("true", "false"):
            value = text == "true"
        elif isinstance(current, int) and isinstance(value, float) and value.is_integer():
            value = int(value)
        settings[name] = value
        bench.reset()
    return Edit(f"{bench.algorithm_name} setting {name}", "" if current is None else str(current),
                lambda text: None if text.strip() else "empty", setter)

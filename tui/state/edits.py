"""Edits of the session's problem, as transactions on model paths.

A table row carries a `Ref`: the path of the model object it shows, from
the problem model (``("targets", 2)``, ``("conditions", 0, "plant",
"blocks", 1)``), never a row index.  An edit copies the problem model,
changes the copy, builds the engine problem from it and, only when that
builds, puts the copy in place and drops the records (`transaction`): a
failed edit leaves the session exactly as it was, with no restore by hand.
The text of every value goes through `sessions.forms.one_line` (parse/format pairs).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from engine.errors import EngineError
from sessions.build import build_problem
from sessions.errors import SessionError
from sessions.format.checks import invalid
from sessions.format.schema import ProblemModel
from sessions.forms import one_line as forms
from sessions.forms import transfers as transfer_forms
from sessions.lifecycle import folder
from tui.state.views import View
from tui.state.workbench import Workbench

if TYPE_CHECKING:  # scipy behind them: imported where used, never before the first paint
    from engine.design.compensator_items import Item
    from engine.design.resonances import Resonance
    from sessions.shaping import GainChoice

Ref = tuple[Any, ...]  # a path into the problem model: attribute names and list indices
Check = Callable[[str], str | None]


@dataclass(frozen=True)
class Edit:
    """One editable value: its title, current text, checker and setter."""

    title: str
    text: str
    check: Check
    apply: Callable[[str], None]


def resolve(root: Any, path: Ref) -> Any:
    """The object at a path (attributes and list indices)."""
    node = root
    for step in path:
        node = node[step] if isinstance(step, int) else getattr(node, step)
    return node


def transaction(bench: Workbench, change: Callable[[ProblemModel], None]) -> None:
    """Apply ``change`` to a copy of the problem model; commit it when the problem
    builds (the records are dropped), else raise `SessionError` and keep the old one.
    A change that leaves the conditions as they were keeps the loops built (a drag's or a
    nudge's parameter values: the plant's forms and tables are not made again)."""
    draft = bench.session.model.problem.model_copy(deep=True)
    try:
        change(draft)
        dumped = draft.model_dump()
        draft = ProblemModel.model_validate(dumped)
        same = draft.conditions == bench.session.model.problem.conditions
        problem = build_problem(
            draft,
            folder(bench.session),
            allow_outside_tables=bench.session.allow_outside_tables or None,
            conditions=bench.session.problem.conditions if same else None,
        )
    except ValidationError as exc:
        raise SessionError(invalid(exc, "problem", dumped)) from None
    except (ValueError, EngineError) as exc:
        raise SessionError(str(exc)) from None
    bench.book.replace_problem(draft, problem)


def set_fields(bench: Workbench, path: Ref, **values: Any) -> None:
    """Set fields of the model object at ``path``, as one transaction."""

    def change(draft: ProblemModel) -> None:
        owner = resolve(draft, path)
        for name, value in values.items():
            setattr(owner, name, value)

    transaction(bench, change)


def set_parameters(bench: Workbench, values: Mapping[str, float], condition: int | None = None) -> None:
    """Parameters' start values (one condition's entry of a per-condition one), as one
    transaction (their bounds checked by the model)."""

    def change(draft: ProblemModel) -> None:
        found = {p.name: p for p in draft.parameters}
        for name, value in values.items():
            if name not in found:
                raise SessionError(f"{name}: no such parameter")
            p = found[name]
            if isinstance(p.value, list):
                p.value = [value if condition in (None, k) else v for k, v in enumerate(p.value)]
            else:
                p.value = value

    transaction(bench, change)


def scale_gain(bench: Workbench, condition: int, factor: float) -> str:
    """Multiply a condition's loop by ``factor`` through its gain parameter (the one the
    loop is proportional to); its name."""
    from sessions.shaping import gain_parameter

    values = bench.session.problem.condition_values(condition)
    name = gain_parameter(bench.session, condition, values)
    set_parameters(bench, {name: values[name] * factor}, condition)
    return name


def compensator_rows(view: View) -> list[tuple[str, str, Any]]:
    """The compensators of the plotted condition's loop as the shaping table lists them:
    (block.item name, reading, the item), at the current design's values (the design on
    screen, the one an edit keeps: `EditFlow.change` makes it the start first)."""
    from engine.design.compensator_items import compensators, named

    problem = view.problem
    if not problem.conditions:
        return []
    k = view.first_plotted
    network = problem.conditions[k].network
    parts = compensators(network, view.parameters(None, k))
    return [
        (f"{label}.{name}", item.reading(network.sample_time), item)
        for label, found in parts.items()
        for name, item in zip(named(found), found)
    ]


def move_item(bench: Workbench, name: str, target: Callable[[float], float]) -> str:
    """Move a compensator's item (``block.item``, or ``block.item.zeta``, of the plotted
    condition) to ``target(now)`` of its frequency, damping or gain, solving for the
    parameters that own it (`engine.design.compensator_moves.move_named`), as one
    transaction; the item's name after the move (`move_items`)."""
    item, zeta, _ = name.rpartition(".zeta") if name.endswith(".zeta") else (name, "", "")
    return move_items(bench, item, [(zeta, target)])


def move_items(bench: Workbench, name: str, moves: list[tuple[str, Callable[[float], float]]]) -> str:
    """`move_item` of one item for several measures (``("", f)`` its frequency, then
    ``(".zeta", g)`` a pair's damping), each solved at the values the one before left, all
    set as one transaction; the item's name after them (items are numbered by frequency:
    a zero moved past another of its kind takes its number, `Move.name`)."""
    from engine.design.compensator_moves import move_named

    problem = bench.session.problem
    k = bench.view().first_plotted
    bounds = {p.name: (p.min, p.max) for p in bench.session.model.problem.parameters}
    values, solved = problem.condition_values(k), {}
    for suffix, target in moves:
        try:
            move = move_named(problem.conditions[k].network, values, name + suffix, target, bounds)
        except EngineError as exc:
            raise SessionError(f"{exc}{bounds_said(bench, name, bounds) if 'bounds' in str(exc) else ''}") from None
        values, solved, name = {**values, **move.values}, {**solved, **move.values}, move.name.removesuffix(suffix)
    set_parameters(bench, solved, k)
    return name


def bounds_said(bench: Workbench, name: str, bounds: Mapping[str, tuple[float | None, float | None]]) -> str:
    """The bounds of the parameters that move item ``name``, as a move they refused names them:
    " (T1: min 0.5, max 10000)"."""
    item = next((item for row, _, item in compensator_rows(bench.view()) if row == name), None)
    said = []
    for p in item.parameters if item is not None else ():
        low, high = bounds.get(p, (None, None))
        sides = [f"{side} {value:g}" for side, value in (("min", low), ("max", high)) if value is not None]
        said += [f"{p}: {', '.join(sides)}"] if sides else []
    return f" ({'; '.join(said)})" if said else ""


def move_root_in_z(bench: Workbench, name: str, z: complex) -> str:
    """`move_root` on a sampled loop's plot (its roots drawn in z, its items in w): a real
    root to the w of the point's real part, a pair's upper root to the point's w."""
    from engine.model.bilinear import w_of_z

    point = z if "pair" in name.rsplit(".", 1)[-1] else complex(z.real)
    return move_root(bench, name, complex(w_of_z(point)))


def move_corner(bench: Workbench, name: str, frequency: float) -> str:
    """Move a compensator's item to a corner frequency (rad/s) of the Bode plot: its
    frequency; in a sampled loop (its items in w), its s-plane equivalent's natural
    frequency, the damping kept (as `overlays.corners` marks it); the item's name after
    the move (`move_items`)."""
    import cmath

    from engine.model.bilinear import s_equivalent

    sample_time = bench.session.problem.conditions[bench.view().first_plotted].network.sample_time
    if sample_time is None:
        return move_item(bench, name, lambda _: frequency)
    item = next((item for row, _, item in compensator_rows(bench.view()) if row == name), None)
    if item is None:
        raise SessionError(f"{name}: no such compensator item")
    _, zeta, _ = s_equivalent(item.root, sample_time)
    s = -frequency if "pair" not in name.rsplit(".", 1)[-1] else frequency * complex(-zeta, (1 - zeta**2) ** 0.5)
    return move_root_in_z(bench, name, cmath.exp(s * sample_time))


PAIR_DAMPING = (0.005, 0.995)  # a dragged pair's damping stays within: a pair in the left half-plane


def move_root(bench: Workbench, name: str, root: complex) -> str:
    """Move a compensator's zero or pole (``block.item``) to a point of the s-plane: a real
    one to the frequency |Re root| (along its half of the axis), a pair's upper root to
    ``root`` (its wn, then its zeta within `PAIR_DAMPING`), as one transaction; the item's
    name after the move (`move_items`)."""
    if "pair" not in name.rsplit(".", 1)[-1]:
        if root.real == 0:
            raise SessionError(f"{name}: not to the origin (drag it along the real axis)")
        return move_item(bench, name, lambda _: abs(root.real))
    if root == 0:
        raise SessionError(f"{name}: a pair not to the origin")
    low, high = PAIR_DAMPING
    zeta = min(max(-root.real / abs(root), low), high)
    return move_items(bench, name, [("", lambda _: abs(root)), (".zeta", lambda _: zeta)])


def add_part(bench: Workbench, block: str, kind: str) -> str:
    """Add a part (`sessions.compensator_parts.PARTS`) to a compensator, placed about the
    plotted condition's crossover (1 rad/s without one), as one transaction; what it added."""
    from sessions.compensator_parts import add_part as added

    view = bench.view()
    curve = view.loop_curve(condition=view.first_plotted)
    w = (curve.margins.crossover_frequency if curve and curve.margins else None) or 1.0
    names: list[str] = []
    k = view.first_plotted
    transaction(bench, lambda draft: names.extend(added(draft, block, kind, w, condition=k)))
    return f"{block}: {kind} added about {w:.4g} rad/s ({', '.join(names)})"


def notch_on(bench: Workbench, block: str, resonance: Resonance) -> str:
    """A notch on a resonance (`engine.design.resonances`) in a compensator, as one
    transaction; what it added."""
    from sessions.compensator_parts import notch_on as added

    names: list[str] = []
    k = bench.view().first_plotted
    transaction(bench, lambda draft: names.extend(added(draft, block, resonance.frequency, resonance.damping, k)))
    return f"{block}: notch on {resonance.text} ({', '.join(names)})"


def resonances(bench: Workbench) -> list[Resonance]:
    """The plotted condition's resonances at the start values (`engine.design.resonances`)."""
    from engine.design.resonances import resonances as found

    problem = bench.session.problem
    if not problem.conditions:
        return []
    k = bench.view().first_plotted
    return found(problem.conditions[k].network, problem.condition_values(k))


def remove_item(bench: Workbench, name: str, item: Item, draft: ProblemModel | None = None) -> str:
    """Delete a compensator's item (``block.item`` of the plotted condition) with the
    factor that holds it, as one transaction (on ``draft`` alone, a copy, to say first
    what would go); what went."""
    from sessions.compensator_parts import remove_item as removed

    block = name.rsplit(".", 1)[0]
    view = bench.view()
    k = view.first_plotted
    lines: list[str] = []
    if draft is not None:  # what would go from the design on screen (the start once the edit is made)
        return "; ".join(removed(draft, block, view.parameters(None, k), item.root, item.kind, k))
    values = bench.session.problem.condition_values(k)
    transaction(bench, lambda draft: lines.extend(removed(draft, block, values, item.root, item.kind, k)))
    return "; ".join(lines)


def gain_for(bench: Workbench, goal: str, target: float) -> str:
    """Scale the plotted condition's gain parameter so its loop has the crossover (rad/s)
    or the phase margin (deg) asked, exactly (`sessions.shaping.solved_gain`); the parameter."""
    from sessions.shaping import solved_gain

    k = bench.view().first_plotted
    name, solution = solved_gain(bench.session, k, goal, target)
    set_parameters(bench, {name: bench.session.problem.condition_values(k)[name] * solution.factor}, k)
    return name


def phase_margin_choices(bench: Workbench, phase_margin: float) -> list[GainChoice]:
    """Every gain of the plotted condition's loop, at the design on screen, that gives
    ``phase_margin`` deg, by crossover frequency, with what else each changes
    (`sessions.shaping.phase_margin_choices`)."""
    from sessions.shaping import phase_margin_choices as choices

    view = bench.view()
    named = dict(view.records[-1].parameters) if view.records else None
    return choices(bench.session, view.first_plotted, phase_margin, named=named)


def change_list(bench: Workbench, path: Ref, change: Callable[[list], None]) -> None:
    """Change the model list at ``path`` in place, as one transaction."""
    transaction(bench, lambda draft: change(resolve(draft, path)))


def checker(parse: Callable[[str], object]) -> Check:
    """A live check from a parser: None when the text reads, else why not."""

    def check(text: str) -> str | None:
        try:
            parse(text)
        except (ValueError, TypeError, EngineError) as exc:
            return str(exc)
        return None

    return check


def field_edit(
    bench: Workbench, path: Ref, name: str, title: str, parse: Callable[[str], Any], format_: Callable[[Any], str]
) -> Edit:
    """An edit of one field of the object at ``path`` through a parse/format pair."""
    current = getattr(resolve(bench.session.model.problem, path), name)
    return Edit(title, format_(current), checker(parse), lambda text: set_fields(bench, path, **{name: parse(text)}))


# -- the plant table ----------------------------------------------------------


def plant_edit(bench: Workbench, ref: Ref) -> Edit | None:
    """The edit of a plant-table row: a block (name, wiring and definition in one
    line), a matrix entry, a junction's signed inputs, a cascade's or a channel's
    transfer, a channel's sub-compensator, or where the loop is broken."""
    model = bench.session.model.problem
    condition = model.conditions[ref[1]]
    if ref[-1] == "break_at":
        return Edit(
            f"{condition.name}: break the loop at signal",
            condition.break_at,
            lambda t: None if t.strip() else "a signal name",
            lambda t: set_fields(bench, ref[:-1], break_at=t.strip()),
        )
    if ref[-1] == "sample_time":
        return Edit(
            f"{condition.name}: sample time T (s; the grid must end below pi/T)",
            forms.format_number(condition.sample_time),
            checker(forms.parse_sample_time),
            lambda t: set_fields(bench, ref[:-1], sample_time=forms.parse_sample_time(t)),
        )
    owner, kind, variable = resolve(model, ref), (ref[-2] if len(ref) >= 2 else ""), condition.variable
    if kind == "junctions":
        return Edit(
            f"{condition.name}: junction {owner.name} -> {owner.output} (+a -b ...)",
            forms.format_signed((owner.plus, owner.minus)),
            checker(forms.parse_signed),
            lambda t: _set_signed(bench, ref, t),
        )
    if kind == "entries":
        return _expression_edit(bench, ref, f"{condition.name}: a[{owner.row},{owner.col}]", variable)
    if kind == "blocks":
        return _block_edit(bench, ref, f"{condition.name}: block {owner.name}", variable)
    if kind == "compensators":
        return field_edit_whole(
            bench,
            ref,
            f"{condition.name}: sub-compensator (ascending powers)",
            transfer_forms.parse_sub_compensator,
            transfer_forms.format_sub_compensator,
        )
    if isinstance(ref[-1], str) and hasattr(owner, "kind"):

        def parse(text: str):
            return transfer_forms.parse_transfer(text, variable, owner)

        edit = field_edit_whole(
            bench,
            ref,
            f"{condition.name}: {ref[-1]} ({TRANSFER_HELP})",
            parse,
            lambda t: transfer_forms.format_transfer(t, variable),
        )
        return Edit(
            edit.title,
            edit.text,
            known_names(bench, parse, lambda t: transfer_forms.transfer_names(t, variable)),
            edit.apply,
        )
    return None


TRANSFER_HELP = "an expression, or factored: / controller: / polynomial: / delay: / table: / state_space: ..."


def field_edit_whole(
    bench: Workbench, path: Ref, title: str, parse: Callable[[str], Any], format_: Callable[[Any], str]
) -> Edit:
    """An edit that replaces the model object at ``path`` (an attribute or a list item of its owner)."""
    current = resolve(bench.session.model.problem, path)
    return Edit(title, format_(current), checker(parse), lambda text: replace_at(bench, path, parse(text)))


def replace_at(bench: Workbench, path: Ref, value: Any) -> None:
    """Put ``value`` at ``path`` (an attribute or a list item), as one transaction."""

    def change(draft: ProblemModel) -> None:
        owner = resolve(draft, path[:-1])
        if isinstance(path[-1], int):
            owner[path[-1]] = value
        else:
            setattr(owner, path[-1], value)

    transaction(bench, change)


def _block_edit(bench: Workbench, ref: Ref, title: str, variable: str) -> Edit:
    """'NAME INPUT OUTPUT DEFINITION': rename, re-wire and redefine a block in one
    edit; a definition alone keeps the name and the wiring."""
    block = resolve(bench.session.model.problem, ref)
    if block.inputs is not None:
        return _ported_block_edit(bench, ref, block, title, variable)

    def parse(text: str) -> dict:
        names, definition = transfer_forms.split_names(text, 3)
        kept = dict(name=block.name, input=block.input, output=block.output)
        wired = None
        if len(names) == 3 and definition:
            try:
                return dict(
                    zip(kept, names), transfer=transfer_forms.parse_transfer(definition, variable, block.transfer)
                )
            except forms.FormError as exc:
                wired = exc  # perhaps a definition with spaces: read the whole line as one below
        try:
            return dict(kept, transfer=transfer_forms.parse_transfer(text, variable, block.transfer))
        except forms.FormError:
            if wired is not None:
                raise forms.FormError(
                    f"{wired} (the line is NAME INPUT OUTPUT DEFINITION, or a definition alone)"
                ) from None
            raise

    quoted = " ".join(transfer_forms.quote_name(n) for n in (block.name, block.input, block.output))
    text = f"{quoted} {transfer_forms.format_transfer(block.transfer, variable)}"
    check = known_names(bench, parse, lambda found: transfer_forms.transfer_names(found["transfer"], variable))
    return Edit(
        f"{title}: NAME INPUT OUTPUT and {TRANSFER_HELP}", text, check, lambda t: set_fields(bench, ref, **parse(t))
    )


def _ported_block_edit(bench: Workbench, ref: Ref, block, title: str, variable: str) -> Edit:
    """A state space of several ports: its definition replaced, its ports' wiring kept (edited in the file)."""

    def parse(text: str) -> dict:
        return dict(transfer=transfer_forms.parse_transfer(text, variable, block.transfer))

    ports = f"{' '.join(block.inputs)} -> {' '.join(block.outputs)}"
    text = transfer_forms.format_transfer(block.transfer, variable)
    check = known_names(bench, parse, lambda found: transfer_forms.transfer_names(found["transfer"], variable))
    return Edit(f"{title} ({ports}): {TRANSFER_HELP}", text, check, lambda t: set_fields(bench, ref, **parse(t)))


def known_names(bench: Workbench, parse: Callable[[str], Any], names_of: Callable[[Any], set[str]]) -> Check:
    """A live check that also flags names that are not parameters of the session."""

    def check(text: str) -> str | None:
        try:
            found = parse(text)
        except (ValueError, TypeError, EngineError) as exc:
            return str(exc)
        parameters = {p.name for p in bench.session.model.problem.parameters}
        unknown = sorted(names_of(found) - parameters)
        if unknown:
            listed = ", ".join(sorted(parameters)[:12]) or "none yet"
            return f"unknown name {unknown[0]!r}: not a parameter (parameters: {listed}; + adds one in Plant)"
        return None

    return check


def _set_signed(bench: Workbench, ref: Ref, text: str) -> None:
    plus, minus = forms.parse_signed(text)
    set_fields(bench, ref, plus=plus, minus=minus)


def _expression_edit(bench: Workbench, path: Ref, title: str, variable: str) -> Edit:
    def parse(text: str) -> str:
        return forms.parse_expression(text, variable)

    from engine.model.expressions import Expression

    edit = field_edit(bench, path, "expression", f"{title} (expression in {variable})", parse, str)
    return Edit(
        edit.title,
        edit.text,
        known_names(bench, parse, lambda text: set(Expression(text, variable).parameters)),
        edit.apply,
    )


def copy_condition(bench: Workbench, ref: Ref, name: str) -> None:
    """A new flight condition copied from the row's; per-condition values get the copied one's."""
    k, name = ref[1], name.strip()
    model = bench.session.model.problem
    if not name or name in [c.name for c in model.conditions]:
        raise SessionError(f"{name!r}: give a new condition name")

    def change(draft: ProblemModel) -> None:
        draft.conditions.append(draft.conditions[k].model_copy(deep=True, update={"name": name}))
        for p in draft.parameters:
            if isinstance(p.value, list):
                p.value = p.value + [p.value[k]]

    transaction(bench, change)


def delete_condition(bench: Workbench, ref: Ref) -> str:
    """Remove the row's flight condition (and its per-condition values); its name."""
    k = ref[1]
    model = bench.session.model.problem
    if len(model.conditions) < 2:
        raise SessionError("a session keeps at least one condition")
    name = model.conditions[k].name

    def change(draft: ProblemModel) -> None:
        draft.conditions.pop(k)
        for p in draft.parameters:
            if isinstance(p.value, list):
                p.value = p.value[:k] + p.value[k + 1 :]

    transaction(bench, change)
    return name


def add_to_plant(bench: Workbench, ref: Ref, text: str) -> None:
    """A new block ('NAME INPUT OUTPUT EXPRESSION') in a diagram, or a new entry
    ('ROW COL EXPRESSION') of a matrix plant, in the row's condition."""
    from sessions.format.schema import BlockModel, ExpressionBlock, MatrixEntry

    condition = bench.session.model.problem.conditions[ref[1]]
    plant = ("conditions", ref[1], "plant")
    if condition.plant.format == "matrix":
        row, col, expression = forms.parse_matrix_entry(text, condition.variable)
        entry = MatrixEntry(row=row, col=col, expression=expression)
        change_list(bench, plant + ("entries",), lambda items: items.append(entry))
    elif condition.plant.format == "diagram":
        name, source, target, expression = forms.parse_block(text, condition.variable)
        block = BlockModel(
            name=name, input=source, output=target, transfer=ExpressionBlock(kind="expression", expression=expression)
        )
        change_list(bench, plant + ("blocks",), lambda items: items.append(block))
    else:
        raise SessionError("blocks are added to block-diagram plants, entries to matrix plants")


def add_check(bench: Workbench, ref: Ref) -> Check:
    """The live check of the plant table's add line for the row's condition."""
    condition = bench.session.model.problem.conditions[ref[1]]
    if condition.plant.format == "matrix":
        return checker(lambda t: forms.parse_matrix_entry(t, condition.variable))
    return checker(lambda t: forms.parse_block(t, condition.variable))


def delete_item(bench: Workbench, ref: Ref) -> str:
    """Delete the list item at ``ref`` (a target, parameter, block or matrix entry); what it was."""
    *owner, index = ref
    if not isinstance(index, int) or owner[-1] not in ("targets", "parameters", "blocks", "entries"):
        raise SessionError("this row cannot be deleted (blocks, matrix entries, targets and parameters can)")
    item = resolve(bench.session.model.problem, ref)
    label = {"targets": "target", "parameters": "parameter", "blocks": "block", "entries": "matrix entry"}
    name = getattr(item, "measure", None) or getattr(item, "name", None) or f"a[{item.row},{item.col}]"
    change_list(bench, tuple(owner), lambda items: items.pop(index))
    return f"{label[owner[-1]]} {name}"

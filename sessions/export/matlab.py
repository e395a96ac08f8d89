"""`loopcraft export --to matlab`: an .m script (Control System Toolbox) of a design.

Each entry a ``tf`` with named input and output (a table an ``frd`` of the table
itself, or with ``--fit`` its AAA fit as a ``zpk``; a delay an exact
``InputDelay``), junctions ``sumblk``, joined by ``connect`` (which joins ``frd``
models too);
the uses of the break signal read an injected loop signal, so the open loop
is ``L = -connect(..., loop, break)`` and ``allmargin(L)`` gives every
margin where it exists; GNU Octave's control package has none, so there the
script calls ``margin(L)`` (the smallest gain and phase margins) and says why.
With several loop breaks, every break's uses read its own loop signal and the
loop at each break (``L_<condition>_at_<break>`` beside the primary's) closes the
others with a ``sumblk`` each: the loop-at-a-time margins.
The closed loop's poles are asked only of a loop with no table (``pole``
refuses ``frd`` models); GNU Octave, whose ``connect`` cannot join ``frd`` models, assembles
a tabulated loop at the tables' frequencies instead (`octave_tables`).  The parameters' values are in a comment: every
entry is written with its numbers.  Numbers are written with Python's
``repr`` (shortest round trip; MATLAB reads the same double).  The script
runs in MATLAB (Control System Toolbox) and in GNU Octave (``pkg load
control``, done by the script when it runs there).
"""

from __future__ import annotations

from sessions.export.design_model import (
    Design,
    ExportCondition,
    ExportEntry,
    fitted_entries,
    identifiers,
    is_junction,
    loop_input,
    refuse_improper,
    rows,
    w_to_z,
)
from sessions.export.octave_tables import assembled_loop, assembles, table_variable


def matlab_script(d: Design, sample_time: float | None = None) -> str:
    """The whole .m script (text) of design ``d``; ``sample_time`` is the z-domain forms' Ts (-1: unstated)."""
    names = identifiers(tuple(c.name for c in d.conditions))
    lines = [
        f"% Design exported by loopcraft from {d.source}, iteration {d.iteration}"
        f"{' (the start)' if d.iteration == 0 else ''}.",
        "% Needs the Control System Toolbox (tf, zpk, frd, sumblk, connect, allmargin or margin),",
        "% or GNU Octave with its control package (loaded here when run by Octave).",
        "% Each condition's loop is broken where the session breaks it: L = GH, 1 + L = 0 closes it.",
        "if exist('OCTAVE_VERSION', 'builtin'), pkg load control; end",
    ]
    for e in fitted_entries(d):
        lines.append(
            f"% {e.label}: {e.text} is tabulated; here its AAA rational fit (engine/numerics/rational_fit.py) of "
            f"degree {e.degree}, relative residual {e.residual:.3e} on the table"
        )
    lines += ["", f"% the parameters of iteration {d.iteration}, written into every entry below:"]
    lines += [f"%   {name} = {_number_or_vector(value)}" for name, value in d.parameters.items()]
    for c in d.conditions:
        lines += [""] + _condition(c, names[c.name], sample_time)
    return "\n".join(lines) + "\n"


def _field(name: str) -> str:
    return identifiers((name,))[name]


def _number_or_vector(value) -> str:
    """A scalar, or a vector of one value per condition (a parameter that differs between them)."""
    if isinstance(value, list):
        return "[" + " ".join(repr(float(v)) for v in value) + "] (one value per condition)"
    return repr(float(value))


def _vector(values) -> str:
    return "[" + " ".join(_complex(v) for v in values) + "]"


def _complex(z) -> str:
    z = complex(z)
    if z.imag == 0:
        return repr(z.real)
    return f"{z.real!r}{'+' if z.imag >= 0 else '-'}{abs(z.imag)!r}i"


# why an improper block is refused where GNU Octave joins the condition with connect (MATLAB's descriptor
# models would take it, but the script must run in both): cip_dual_channel --fit gave |L| 666 at loopcraft's
# crossover (where it is 1), the same loop with a pole at 1e4 rad/s added to each improper block gave 1.0
OCTAVE_IMPROPER = (
    "GNU Octave's connect joins improper blocks as descriptor systems, not reliably (wrong loops seen); give it "
    "a far pole (as the pid template's filtered derivative)"
)


def _condition(c: ExportCondition, name: str, sample_time: float | None) -> list[str]:
    if not assembles(c):  # (an assembled loop evaluates each block's response: an improper one is exact)
        fitted = any(e.kind == "fitted" for e in c.entries)
        refuse_improper(c, OCTAVE_IMPROPER + (", or export the tables themselves (leave out --fit)" if fitted else ""))
    loops = {b: loop_input(c, b) for b in c.breaks or (c.break_at,)}
    lines = [
        f"%% condition '{c.name}' (variable {c.variable}"
        f"{'; the w-plane, w = (z - 1)/(z + 1), written as s' if c.variable == 'w' else ''})",
        f"blocks_{name} = {{}};",
    ]
    for signal, entries in rows(c):
        lines += _row(c, name, signal, entries, loops)
    connected = _connected(c, name, loops)
    if assembles(c):
        connected = [
            "if exist('OCTAVE_VERSION', 'builtin')",
            *assembled_loop(c, name, _vector),
            "else",
            *(f"  {line}" for line in connected),
            "end",
        ]
    lines += connected
    if any(e.kind == "table" for e in c.entries):
        lines.append("% no closed-loop poles: a tabulated entry (frd) has none (pole refuses frd models)")
    else:
        lines.append(f"poles_{name} = pole(closed_{name})")
    return lines + (_z_forms(c, name, sample_time) if c.variable == "w" else [])


def _connected(c: ExportCondition, name: str, loops: dict[str, str]) -> list[str]:
    """The open loop at the primary break (and, with several breaks, at each other one), every
    other loop closed by a sumblk joining its loop signal to its break; their margins; the closed loop."""
    ident = identifiers(c.signals)
    produced = [ident[s] for s, _ in rows(c)]
    inputs = [ident[s] for s in c.inputs]
    cells = f"blocks_{name}{{:}}"

    def closing(cut: str | None) -> str:  # connect's sumblks closing every loop but cut's
        return "".join(f", sumblk('{loop} = {ident[b]}')" for b, loop in loops.items() if b != cut)

    lines = [
        f"L_{name} = -connect({cells}{closing(c.break_at)}, '{loops[c.break_at]}', '{ident[c.break_at]}');"
        f"  % open loop at '{c.break_at}'{' (the other loops closed)' if c.breaks else ''}",
        "% every margin (allmargin); GNU Octave's control package has no allmargin: there margin gives",
        "% the smallest gain margin (a ratio) and phase margin (deg) with their frequencies (rad/s)",
        _margins(name),
    ]
    for b in c.breaks:
        if b != c.break_at:
            at = f"{name}_at_{ident[b]}"
            lines += [
                f"L_{at} = -connect({cells}{closing(b)}, '{loops[b]}', '{ident[b]}');  % open loop at '{b}', "
                "the other loops closed",
                _margins(at),
            ]
    return lines + [
        f"closed_{name} = connect({cells}{closing(None)}, {_cell(inputs)}, {_cell(produced)});  % all loops closed"
    ]


def _margins(at: str) -> str:
    """The margins of L_<at>: allmargin where it exists (MATLAB), else margin (GNU Octave)."""
    return f"if exist('allmargin'), margins_{at} = allmargin(L_{at}), else, [Gm_{at}, Pm_{at}, Wcg_{at}, Wcp_{at}] = margin(L_{at}), end"


def _z_forms(c: ExportCondition, name: str, sample_time: float | None) -> list[str]:
    """A w-plane condition's compensators in z (Ts: ``sample_time``, else -1, unstated)."""
    ts = "-1" if sample_time is None else repr(float(sample_time))
    lines = []
    for e in c.entries:
        if e.compensator and e.kind == "rational":
            numz, denz = w_to_z(e.num, e.den)
            lines.append(
                f"Cz_{name}_{_field(e.label)} = tf({_vector(numz)}, {_vector(denz)}, {ts})  "
                f"% {e.label} in z (Ts {ts}{': unstated' if sample_time is None else ''})"
            )
    return lines


def _cell(names: list[str]) -> str:
    return "{" + ", ".join(f"'{n}'" for n in names) + "}"


def _row(c: ExportCondition, name: str, signal: str, entries: list[ExportEntry], loops: dict[str, str]) -> list[str]:
    """The systems defining one signal: a block, a sumblk, or blocks summed by a sumblk; a use of
    a break reads its loop signal (``loops``)."""
    out = c.ident(signal)

    def reads(e: ExportEntry) -> str:
        return loops.get(e.input) or c.ident(e.input)

    if len(entries) == 1:
        return _system(entries[0], reads(entries[0]), out, name)
    if is_junction(entries):
        terms = " ".join(("- " if e.constant < 0 else "+ ") + reads(e) for e in entries).removeprefix("+ ")
        return [f"blocks_{name}{{end+1}} = sumblk('{out} = {terms}');  % {entries[0].label}"]
    lines = []
    for k, e in enumerate(entries, start=1):
        lines += _system(e, reads(e), f"{out}__{k}", name)
    terms = " + ".join(f"{out}__{k}" for k in range(1, len(entries) + 1))
    return lines + [f"blocks_{name}{{end+1}} = sumblk('{out} = {terms}');"]


def _system(e: ExportEntry, source: str, out: str, name: str) -> list[str]:
    role = "compensator" if e.compensator else "plant"
    names = f"'InputName', '{source}', 'OutputName', '{out}'"
    if e.kind == "delay":
        make = f"tf(1, 1, 'InputDelay', {e.delay!r}, {names})"
        comment = f"{e.label} ({role}): {e.text}"
    elif e.kind == "table":
        table = table_variable(name, e)
        comment = f"{e.label} ({role}): {e.text}, the table itself ({len(e.omega)} frequencies, rad/s)"
        return [
            f"% {comment}",
            f"{table} = frd({_vector(e.response)}, {_vector(e.omega)}, {names});",
            f"blocks_{name}{{end+1}} = {table};",
        ]
    elif e.kind == "fitted":
        make = f"zpk({_vector(e.zeros)}, {_vector(e.poles)}, {e.gain!r}, {names})"
        comment = f"{e.label} ({role}): AAA fit of {e.text}, degree {e.degree}, residual {e.residual:.3e}"
    elif e.kind == "state_space":
        A, B, C, D = e.matrices
        dt = "" if e.sample_time is None else f", {e.sample_time!r}"
        rows = "; ".join(" ".join(repr(x) for x in r) for r in A)
        make = f"ss([{rows}], {_vector(B)}.', {_vector(C)}, {D!r}{dt}, {names})"
        comment = f"{e.label} ({role}): {e.text}, A, B, C, D as given"
    elif e.sample_time is not None:  # in z
        make = f"tf({_vector(e.num)}, {_vector(e.den)}, {e.sample_time!r}, {names})"
        comment = f"{e.label} ({role}): {e.text} (in z, Ts {e.sample_time!r} s)"
    else:
        make = f"tf({_vector(e.num)}, {_vector(e.den)}, {names})"
        comment = f"{e.label} ({role}): {e.text}"
    return [f"% {comment}", f"blocks_{name}{{end+1}} = {make};"]

"""A tabulated loop in the MATLAB script as GNU Octave runs it.

MATLAB's ``connect`` joins ``frd`` models; GNU Octave's control package cannot (its
``__sys_connect__`` multiplies matrices of the wrong sizes) and its ``margin`` refuses them.
So, when Octave runs the script, the open loop of a condition with a table is assembled
at the tables' common frequencies from each entry's response there: the signals x solve
x = M x + b at each frequency (M(i, j) the entries from signal j to signal i, b the
entries reading the injected loop signal), L = -x(break), as ``-connect`` gives it in
MATLAB; ``L_<condition>`` is then ``frd(L, w)``, and its margins are left to MATLAB (or
``export --fit``)."""

from __future__ import annotations

from functools import reduce

from sessions.export.design_model import ExportCondition, ExportEntry, identifiers


def table_variable(name: str, e: ExportEntry) -> str:
    """The variable holding a table's frd model in condition ``name``'s section."""
    return f"table_{name}_{identifiers((e.label,))[e.label]}"


def assembles(c: ExportCondition) -> bool:
    """Whether Octave assembles the condition's loop so: continuous, with a table, its other entries
    rational or delays (a state-space block beside a table is left to MATLAB), its tables sharing some
    frequencies."""
    kinds = {e.kind for e in c.entries}
    return c.variable == "s" and "table" in kinds and kinds <= {"table", "rational", "delay"} and bool(_common(c))


def _common(c: ExportCondition) -> list[float]:
    """The frequencies every table of the condition has."""
    return sorted(reduce(lambda a, b: a & b, (set(e.omega) for e in c.entries if e.kind == "table")))


def assembled_loop(c: ExportCondition, name: str, vector) -> list[str]:
    """Octave's lines making ``L_<name>`` (an frd) for condition ``c`` (one that `assembles`);
    ``vector`` writes a list of numbers as a MATLAB row vector."""
    common = _common(c)
    index = {s: k for k, s in enumerate(c.signals, start=1)}
    lines = [
        "  % GNU Octave's control package cannot connect frd models: L is assembled at the tables' common",
        "  % frequencies from each entry's response there (x = M x + b, b: the loop signal injected, L = -x(break))",
        f"  w_{name} = {vector(common)};",
        f"  s_{name} = 1i * w_{name};",
    ]
    terms = []
    for k, e in enumerate(c.entries, start=1):
        lines.append(f"  g_{name}{{{k}}} = {_response(e, name, vector)};  % {e.label}")
        if e.kind == "table":  # its values at the common frequencies
            t = table_variable(name, e)
            lines.append(f"  g_{name}{{{k}}} = g_{name}{{{k}}}(lookup({t}.w, w_{name}));")
        where = "b" if e.input == c.break_at else f"M({index[e.output]}, {index[e.input]})"
        target = f"b({index[e.output]})" if where == "b" else where
        terms.append(f"{target} = {target} + g_{name}{{{k}}}(k);")
    n = len(c.signals)
    lines += [
        f"  H_{name} = zeros(size(w_{name}));",
        f"  for k = 1:numel(w_{name})",
        f"    M = zeros({n}); b = zeros({n}, 1);",
        *(f"    {t}" for t in terms),
        f"    x = (eye({n}) - M) \\ b;",
        f"    H_{name}(k) = -x({index[c.break_at]});",
        "  end",
        f"  L_{name} = frd(H_{name}, w_{name});",
        "  % Octave's margin refuses frd models: no margins here (MATLAB's allmargin, or export --fit)",
    ]
    return lines


def _response(e: ExportEntry, name: str, vector) -> str:
    """The entry's response at s_<name> (a row vector), as an Octave expression."""
    s = f"s_{name}"
    if e.kind == "table":  # (MATLAB parses this branch too: no indexing of a call's result)
        t = table_variable(name, e)
        return f"reshape({t}.H, 1, [])"
    if e.kind == "delay":
        return f"exp(-{e.delay!r} * {s})"
    if e.constant is not None:
        return f"repmat({e.constant!r}, size({s}))"
    return f"polyval({vector(e.num)}, {s}) ./ polyval({vector(e.den)}, {s})"

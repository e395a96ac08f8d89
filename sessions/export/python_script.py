"""`loopcraft export --to python`: a runnable python-control script of a design.

A unity loop (every block on the loop's one chain) is written compactly: each block a
``control.tf`` (a table a ``control.frd`` of the table itself; with ``--fit`` its AAA
fit as a ``zpk``; a delay a Pade approximation) and the open loop their product,
``L = C * P``; the closed loop ``control.feedback(L, 1)``.  Any other diagram is
rebuilt entry by entry (`sessions.export.design_model`): junctions
``control.summing_junction``, joined by name with ``control.interconnect``, whose uses
of the break signal read an injected loop signal, so ``L = -(break signal)/(loop
signal)``; a table there needs ``--fit`` (``interconnect`` joins no ``frd``).  Numbers
are written with ``repr`` (the shortest text that reads back to the same float).  The
script prints each condition's margins as python-control finds them
(``control.stability_margins``) beside loopcraft's (how obtained), says where
python-control is known to differ, and the closed-loop poles; ``--json`` prints them.
"""

from __future__ import annotations

import numpy as np

from sessions.errors import SessionError
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

PADE_ORDER = 6
DIFFERS = {
    "table": "python-control reads an frd's margins off the table's own frequencies (interpolated between "
    "them); loopcraft refines them on a rational fit of the table and states its residual",
    "rational": "python-control roots the expanded loop's polynomials: at high order or near light modes its "
    "crossings can be off in the fourth digit, and it may list spurious ones (a gain margin at 0 rad/s of a "
    "type-k loop, a crossing where |L| ~ 1e-30); loopcraft's are refined and certified (docs/margins.md)",
}


def python_script(d: Design, sample_time: float | None = None, ours: dict | None = None) -> str:
    """The whole script (text) of design ``d``; ``sample_time`` labels w-plane designs'
    z-domain forms; ``ours``: loopcraft's margins by condition, printed beside python-control's."""
    names = identifiers(tuple(c.name for c in d.conditions))
    parts = [_header(d), _parameters(d), f"# loopcraft's margins, by condition\nLOOPCRAFT = {ours or {}!r}"]
    for c in d.conditions:
        parts.append(_compact(c, names[c.name]) if c.chain is not None else _condition(c, names[c.name]))
        parts.append(_z_domain(c, names[c.name], sample_time))
    table = ", ".join(
        f"{c.name!r}: ({names[c.name]}_loop, {names[c.name]}_closed, {names[c.name]}_z)" for c in d.conditions
    )
    parts.append(f"# condition -> (open loop, closed loop, z-domain compensators)\nCONDITIONS = {{{table}}}\n")
    several = ", ".join(
        f"{c.name!r}: ({names[c.name]}_loop_at, {names[c.name]}_loops, {c.breaks!r})" for c in d.conditions if c.breaks
    )
    parts.append(
        "# conditions with several loop breaks -> (the loop at one, the others closed; every break at once; "
        f"the breaks)\nBREAKS = {{{several}}}\n"
    )
    differs = {c.name: DIFFERS["table" if _has_table(c) else "rational"] for c in d.conditions}
    parts.append(f"# where python-control is known to differ, by condition\nDIFFERS = {differs!r}\n")
    parts.append(MAIN)
    return "\n\n".join(parts)


def _has_table(c: ExportCondition) -> bool:
    return any(e.kind == "table" for e in c.entries)


def _header(d: Design) -> str:
    lines = [
        f'"""Design exported by loopcraft from {d.source}, iteration {d.iteration}'
        f"{' (the start)' if d.iteration == 0 else ''}.",
        "",
        "Rebuilds every flight condition with python-control, breaks the loop where the",
        "session does and prints the margins (control.stability_margins) and the",
        "closed-loop poles.  Run:  python THIS_FILE.py [--json]",
        '"""',
    ]
    for e in fitted_entries(d):
        lines.append(
            f"# {e.label}: {e.text} is tabulated; here its AAA rational fit (engine/numerics/rational_fit.py) "
            f"of degree {e.degree}, relative residual {e.residual:.3e} on the table"
        )
    lines += ["import json", "import sys", "", "import control", "import numpy as np"]
    if fitted_entries(d):
        lines += ["", "", ZPK]
    return "\n".join(lines)


def _parameters(d: Design) -> str:
    body = "".join(f"    {name!r}: {value!r},\n" for name, value in d.parameters.items())
    return (
        f"# the parameters of iteration {d.iteration} (a list: one value per condition); the blocks "
        f"below are computed from them\nPARAMETERS = {{\n{body}}}"
    )


def _compact(c: ExportCondition, name: str) -> str:
    """A unity loop: its blocks, L their product (the junction's sign folded in), the
    closed loop control.feedback(L, 1) (None with a table: an frd has no poles)."""
    labels = identifiers(tuple(dict.fromkeys(e.label for e in c.entries)))
    sign, lines, factors, tables = -1.0, [], [], []
    for number in c.chain:
        e = c.entries[number]
        if e.constant is not None:
            sign *= e.constant
            continue
        role = "compensator" if e.compensator else "plant"
        lines += [f"    # {e.label} ({role}): {_what(e)}", f"    {labels[e.label]} = {_make(e, '')}"]
        (tables if e.kind == "table" else factors).append(labels[e.label])
    product = " * ".join(tables + factors) or "control.tf(1, 1)"  # an frd first: it takes the tf's on
    body = product if sign == 1.0 else f"{sign!r} * {product}"
    closed = (
        "    return None  # an frd: the table's response, no poles"
        if tables
        else f"    return control.feedback({name}_loop(), 1)"
    )
    return "\n".join(
        [
            f"def {name}_loop():",
            f'    """Condition {c.name!r} (variable {c.variable}), a unity loop: L = GH broken at {c.break_at!r}."""',
            *lines,
            f"    return {body}",
            "",
            "",
            f"def {name}_closed():",
            '    """The closed loop, 1 + L = 0."""',
            closed,
        ]
    )


def _what(e: ExportEntry) -> str:
    if e.kind == "table":
        return f"{e.text}, the table itself ({len(e.omega)} frequencies)"
    if e.kind == "fitted":
        return f"AAA fit of {e.text}, degree {e.degree}, residual {e.residual:.3e}"
    if e.kind == "delay":
        return f"{e.text}, a Pade approximation of order {PADE_ORDER}"
    return e.text


def _make(e: ExportEntry, names: str) -> str:
    """The python-control system of one entry (``names``: its signal names, or '')."""
    named = f", {names}" if names else ""
    if e.kind == "table":
        response = np.asarray(e.response)
        return (
            f"control.frd(np.array({response.real.tolist()!r}) + 1j * np.array({response.imag.tolist()!r}), "
            f"np.array({list(e.omega)!r}){named})"
        )
    if e.kind == "delay":
        return f"control.tf(*control.pade({e.delay!r}, {PADE_ORDER}){named})"
    if e.kind == "fitted":
        return f"zpk({list(e.zeros)!r}, {list(e.poles)!r}, {e.gain!r}{named})"
    dt = "" if e.sample_time is None else f", {e.sample_time!r}"  # in z, every {sample_time} s
    if e.kind == "state_space":
        A, B, C, D = e.matrices
        n = len(B)
        return (
            f"control.ss(np.array({[list(r) for r in A]!r}).reshape({n}, {n}), np.array({list(B)!r}).reshape({n}, 1), "
            f"np.array({list(C)!r}).reshape(1, {n}), {D!r}{dt}{named})"
        )
    return f"control.tf({list(e.num)!r}, {list(e.den)!r}{dt}{named})"


def _condition(c: ExportCondition, name: str) -> str:
    if _has_table(c):
        raise SessionError(
            f"condition {c.name!r}: a table in a diagram that is not a unity loop: python-control's interconnect "
            "joins no frd; export its rational fit with --fit"
        )
    refuse_improper(c, "python-control's interconnect cannot realize it in a diagram that is not a unity loop")
    cut = loop_input(c)
    ident = identifiers(c.signals)
    produced = [ident[s] for s, _ in rows(c)]
    inputs = [ident[s] for s in c.inputs]
    lines = _blocks_head(c, name, cut)
    for signal, entries in rows(c):
        lines += ["        " + line for line in _row(c, signal, entries, cut)]
    lines += [
        "    ]",
        "",
        "",
        f"def {name}_loop():",
        f'    """The open loop L = GH broken at {c.break_at!r} (1 + L = 0 closes it)."""',
        f"    broken = control.interconnect({name}_blocks(), inplist=[{cut!r}], "
        f"outlist=[{ident[c.break_at]!r}], check_unused=False)",
        "    return -broken",
        "",
        "",
        f"def {name}_closed():",
        f'    """The closed loop (the loop signal fed back from {c.break_at!r}): from the inputs '
        f'{inputs} to every signal {produced}."""',
        f"    broken = control.interconnect({name}_blocks(), inplist={inputs + [cut]!r}, "
        f"outlist={produced!r}, check_unused=False)",
        f"    back = np.zeros(({len(inputs) + 1}, {len(produced)}))",
        f"    back[-1, {produced.index(ident[c.break_at])}] = 1.0",
        "    closed = control.feedback(broken, back, sign=1)   # solves an algebraic loop, if any",
        f"    return closed[:, :{len(inputs)}]" if inputs else "    return closed",
    ]
    return "\n".join(lines + _at_breaks(c, name))


def _blocks_head(c: ExportCondition, name: str, cut: str) -> list[str]:
    """The blocks function's head: broken at ``break_at`` alone, or (a condition with several
    breaks) at the breaks ``cuts`` names, each use of one reading its loop signal (``reads``)."""
    if not c.breaks:
        return [
            f"def {name}_blocks():",
            f'    """Condition {c.name!r} (variable {c.variable}): its blocks and junctions; the uses of '
            f'{c.break_at!r} read the loop signal {cut!r}."""',
            "    return [",
        ]
    loops = {b: (c.ident(b), loop_input(c, b)) for b in c.breaks}
    return [
        f"# condition {c.name!r}'s loop breaks: name -> (signal, the loop signal its uses read when broken)",
        f"{name.upper()}_BREAKS = {loops!r}",
        "",
        "",
        f"def {name}_blocks(cuts=({c.break_at!r},)):",
        f'    """Condition {c.name!r} (variable {c.variable}): its blocks and junctions; the uses of each '
        f'break in cuts read its loop signal ({name.upper()}_BREAKS), every other loop stays closed."""',
        f"    loops = {{{name.upper()}_BREAKS[b][0]: {name.upper()}_BREAKS[b][1] for b in cuts}}",
        "",
        "    def reads(signal):",
        "        return loops.get(signal, signal)",
        "",
        "    return [",
    ]


def _at_breaks(c: ExportCondition, name: str) -> list[str]:
    """A condition with several breaks: the loop at any one (the others closed by interconnect,
    joined by name) and the loop matrix broken at every break at once."""
    if not c.breaks:
        return []
    table = f"{name.upper()}_BREAKS"
    return [
        "",
        "",
        f"def {name}_loop_at(cut):",
        f'    """The loop broken at the break cut ({table}), every other loop closed: L = -(cut)/(its loop signal)."""',
        f"    signal, loop = {table}[cut]",
        f"    broken = control.interconnect({name}_blocks((cut,)), inplist=[loop], outlist=[signal], check_unused=False)",
        "    return -broken",
        "",
        "",
        f"def {name}_loops():",
        f'    """Every break at once: the square loop matrix L = -(breaks)/(their loop signals), in {table}\'s order."""',
        f"    cuts = tuple({table})",
        f"    broken = control.interconnect({name}_blocks(cuts), inplist=[{table}[b][1] for b in cuts], "
        f"outlist=[{table}[b][0] for b in cuts], check_unused=False)",
        "    return -broken",
    ]


def _reads(entry: ExportEntry, c: ExportCondition, cut: str) -> str:
    """The text of the signal an entry reads: a literal, or (a condition with several breaks) a
    break's ``reads(...)``, its loop signal where the blocks are cut there."""
    if entry.input in c.breaks:
        return f"reads({c.ident(entry.input)!r})"
    return repr(cut if entry.input == c.break_at else c.ident(entry.input))


def _row(c: ExportCondition, signal: str, entries: list[ExportEntry], cut: str) -> list[str]:
    """The systems defining one signal: a block, a summing junction, or blocks summed."""
    out = c.ident(signal)
    labels = identifiers(tuple(dict.fromkeys(e.label for e in c.entries)))
    if len(entries) == 1:
        return _system(entries[0], _reads(entries[0], c, cut), out, labels[entries[0].label])
    if is_junction(entries):
        signed = ", ".join(_signed(_reads(e, c, cut), e.constant < 0) for e in entries)
        return [f"control.summing_junction(inputs=[{signed}], output={out!r}, name={labels[entries[0].label]!r}),"]
    lines, terms = [], []
    for k, e in enumerate(entries, start=1):
        lines += _system(e, _reads(e, c, cut), f"{out}__{k}", f"{labels[e.label]}__{k}")
        terms.append(f"{out}__{k}")
    return lines + [f"control.summing_junction(inputs={terms!r}, output={out!r}, name={out + '__sum'!r}),"]


def _signed(source: str, negative: bool) -> str:
    """A junction's input text with its sign: '-x' for a literal, '-' + reads('x') for a break."""
    if not negative:
        return source
    return repr("-" + source[1:-1]) if source[0] in "'\"" else f"'-' + {source}"


def _system(e: ExportEntry, source: str, out: str, name: str) -> list[str]:
    """One entry as a named SISO system (``source``: the text of what it reads), with a comment
    saying what it is."""
    role = "compensator" if e.compensator else "plant"
    names = f"inputs={source}, outputs={out!r}, name={name!r}"
    return [f"# {e.label} ({role}): {_what(e)}", f"{_make(e, names)},"]


def _z_domain(c: ExportCondition, name: str, sample_time: float | None) -> str:
    """w-plane conditions: each compensator in z by w = (z - 1)/(z + 1)."""
    dt = "True" if sample_time is None else repr(float(sample_time))
    lines = [
        f"def {name}_z():",
        '    """The compensators in the z-domain (w-plane conditions; dt True: sample time unstated)."""',
    ]
    items = []
    if c.variable == "z":  # the compensators as typed, in z
        lines[1] = f'    """The compensators in z (every {c.sample_time!r} s)."""'
        items = [
            f"        {e.label!r}: control.tf({list(e.num)!r}, {list(e.den)!r}, {c.sample_time!r}),"
            for e in c.entries
            if e.compensator and e.kind == "rational"
        ]
    if c.variable == "w":
        for e in c.entries:
            if e.compensator and e.kind == "rational":
                numz, denz = w_to_z(e.num, e.den)
                items.append(f"        {e.label!r}: control.tf({numz!r}, {denz!r}, {dt}),")
    lines += ["    return {"] + items + ["    }"]
    return "\n".join(lines)


ZPK = '''def zpk(zeros, poles, gain, **names):
    """gain * prod(s - zeros) / prod(s - poles) with real coefficients (conjugate roots)."""
    return control.tf(gain * np.real(np.poly(zeros)), np.real(np.poly(poles)), **names)'''


MAIN = '''DISK_GRID_POINTS = 2000  # python-control's disk_margins is evaluated on this many points


def dense_grid(loop, points=20000):
    """Frequencies two decades either side of the loop's poles and zeros (below Nyquist in z)."""
    roots = np.concatenate([np.atleast_1d(control.poles(loop)), np.atleast_1d(control.zeros(loop))])
    if loop.isdtime(strict=True):
        roots = np.log(roots[roots != 0].astype(complex)) / loop.dt
    size = np.abs(roots[np.isfinite(roots) & (roots != 0)])
    low, high = (size.min() / 100, size.max() * 100) if size.size else (1e-3, 1e3)
    w = np.logspace(np.log10(low), np.log10(high), points)
    return w[w < np.pi / loop.dt] if loop.isdtime(strict=True) else w


def stability_margins(loop):
    """Every crossing control.stability_margins finds (gain margins absolute, phase margins deg).
    Its polynomial method roots the expanded loop; at high order a spurious far root can overflow
    numpy's evaluation there: that overflow is raised (not printed, not silenced) and python-control
    is asked again on the loop's response on a dense grid (its FRD method), which "method" names."""
    try:
        with np.errstate(over="raise"):
            gm, pm, sm, wpc, wgc, wms = control.stability_margins(loop, returnall=True)
        method = "polynomial"
    except FloatingPointError:
        w = dense_grid(loop)
        gm, pm, sm, wpc, wgc, wms = control.stability_margins(control.frd(loop, w, smooth=True), returnall=True)
        method = f"FRD on {w.size} points (its polynomial method overflowed)"
    ratios = [float(x) for x in np.atleast_1d(gm)]
    with np.errstate(divide="ignore"):
        decibels = [float(20 * np.log10(x)) if x > 0 else None for x in ratios]
    return {"gain_margins_ratio": ratios,
            "gain_margins_db": decibels,
            "gain_margins": ratios,  # the ratios' old key: kept one release (docs/export.md)
            "phase_crossovers": [float(x) for x in np.atleast_1d(wpc)],
            "phase_margins_deg": [float(x) for x in np.atleast_1d(pm)],
            "gain_crossovers": [float(x) for x in np.atleast_1d(wgc)],
            "stability_margins": [float(x) for x in np.atleast_1d(sm)],
            "stability_frequencies": [float(x) for x in np.atleast_1d(wms)],
            "python_control_method": method}


def response(loop, w):
    """L(j w) (z = exp(j w T) in z): a state space by solving (s I - A) x = B, a fraction in its
    factored form k prod(s - z) / prod(s - p), so a high order overflows nothing."""
    s = np.exp(1j * w * loop.dt) if loop.isdtime(strict=True) else 1j * w
    if isinstance(loop, control.StateSpace):
        A, B, C, D = (np.asarray(m, dtype=float) for m in (loop.A, loop.B, loop.C, loop.D))
        return complex((C @ np.linalg.solve(s * np.eye(A.shape[0]) - A, B) + D)[0, 0])
    num, den = loop.num[0][0], loop.den[0][0]
    gain = num[np.flatnonzero(num)[0]] / den[np.flatnonzero(den)[0]]
    return complex(gain * np.prod(s - np.roots(num)) / np.prod(s - np.roots(den)))


def why_alone(loop, what, w):
    """Why a crossing python-control lists alone is no margin: L where it puts it."""
    if w == 0:
        return "at 0 rad/s: the limit of a loop with integrators (|L| infinite), no crossing"
    h = response(loop, w)
    if what == "phase margin" and abs(abs(h) - 1) > 1e-3:
        return f"not a gain crossover: |L| = {abs(h):.6g} there (rounding in its expanded polynomials)"
    if what == "gain margin" and abs(np.angle(h, deg=True)) < 179.9:
        return f"not a phase crossover: arg L = {np.angle(h, deg=True):.6g} deg there (rounding in its polynomials)"
    return f"L = {h:.6g} there: a crossing loopcraft does not list"


def side_by_side(what, unit, theirs, ours, loop):
    """Each margin beside the other tool's at the nearest frequency; one python-control lists alone
    with why it is not a margin (L evaluated there)."""
    left = list(theirs)

    def apart(a, b):
        if a == b:
            return 0.0
        return abs(np.log(a / b)) if a > 0 and b > 0 else np.inf

    for value, w in ours:
        k = min(range(len(left)), key=lambda i: apart(left[i][1], w), default=None)
        if k is not None and apart(left[k][1], w) < 0.1:
            mine = left.pop(k)
            text = f"{mine[0]:.6g} {unit} at {mine[1]:.6g}"
        else:
            text = "-"
        print(f"  {what:<14}{text:<30}{value:.6g} {unit} at {w:.6g} rad/s")
    for value, w in left:
        print(f"  {what:<14}{f'{value:.6g} {unit} at {w:.6g}':<30}- (python-control alone: {why_alone(loop, what, w)})")


def summary(loop):
    """L in one or a few lines: a fraction as its zeros, poles and gain; a state space by its size."""
    if isinstance(loop, control.StateSpace):
        return f"state space, {loop.nstates} states (python-control's interconnect; not printed)"
    num, den = loop.num[0][0], loop.den[0][0]
    gain = num[np.flatnonzero(num)[0]] / den[np.flatnonzero(den)[0]]
    roots = lambda r: ", ".join(f"{x:.6g}" for x in sorted(r, key=lambda x: (abs(x), x.imag))) or "none"
    return f"gain {gain:.6g}\\n  zeros: {roots(np.roots(num))}\\n  poles: {roots(np.roots(den))}"


def disk_margin_grid(loop):
    """python-control's disk_margins (skew 0) of one loop on the dense grid, and the grid's size:
    grid-based, so an upper bound of alpha (a peak between two points is missed)."""
    w = dense_grid(loop, DISK_GRID_POINTS)
    return float(control.disk_margins(loop, w)[0]), int(w.size)


def multi_loop_grid(loops):
    """python-control's disk_margins of the loop matrix (every break at once) on a grid, and how
    obtained; it needs slycot (ab13md, the mu upper bound): without it, None and why."""
    try:
        import slycot  # noqa: F401
    except ImportError:
        return None, "not compared: python-control's MIMO disk_margins needs slycot (ab13md), not installed"
    w = dense_grid(loops, DISK_GRID_POINTS)
    return float(control.disk_margins(loops, w)[0]), f"python-control's disk_margins (slycot's mu bound) on {w.size} points"


def at_breaks(name):
    """Every break of a condition loop at a time (python-control's margins, its grid disk margin)
    and the multi-loop disk margin."""
    loop_at, loops, names = BREAKS[name]
    found = {}
    for cut in names:
        loop = loop_at(cut)
        found[cut] = stability_margins(loop)
        found[cut]["disk_margin_grid"], found[cut]["disk_grid_points"] = disk_margin_grid(loop)
    alpha, how = multi_loop_grid(loops())
    return found, {"alpha_grid": alpha, "how": how}


def print_breaks(name, found, together, ours):
    """Each break's margins beside loopcraft's, then the multi-loop disk margins."""
    for cut, r in found.items():
        mine = ours.get("breaks", {}).get(cut, {})
        print(f"  at break {cut} (the other loops closed):")
        theirs = [(db, w) for db, w in zip(r["gain_margins_db"], r["phase_crossovers"]) if db is not None]
        side_by_side("gain margin", "dB", theirs, mine.get("gain", []), BREAKS[name][0](cut))
        side_by_side("phase margin", "deg", list(zip(r["phase_margins_deg"], r["gain_crossovers"])),
                     mine.get("phase", []), BREAKS[name][0](cut))
        print(f"  {'disk margin':<14}{r['disk_margin_grid']:<30.6g}{shown(mine.get('disk'))}  "
              f"(python-control: disk_margins on {r['disk_grid_points']} points, grid-based; loopcraft: refined)")
    alpha = together["alpha_grid"]
    print(f"  multi-loop disk margin: loopcraft {shown(ours.get('multi_loop'))} (certified); python-control "
          + (f"{alpha:.6g}, {together['how']}" if alpha is not None else together["how"]))


def shown(value):
    return "not found" if value is None else f"{value:.6g}"


def main():
    report = {}
    for name, (loop, closed, _) in CONDITIONS.items():
        found = stability_margins(loop())
        system = closed()
        if system is not None:
            poles = control.poles(system)
            found["closed_loop_poles"] = [[float(p.real), float(p.imag)] for p in poles]
            found["stable"] = bool(np.all(np.abs(poles) < 1) if system.isdtime(strict=True) else np.all(poles.real < 0))
        found["loopcraft"] = LOOPCRAFT.get(name, {})
        if name in BREAKS:
            found["breaks"], found["multi_loop"] = at_breaks(name)
        report[name] = found
    if "--json" in sys.argv[1:]:
        print(json.dumps(report, indent=2))
        return
    for name, r in report.items():
        verdict = ("stable" if r["stable"] else "UNSTABLE") + " closed loop" if "stable" in r else "a table: no poles"
        print(f"condition {name}: {verdict}")
        loop = CONDITIONS[name][0]()
        if not isinstance(loop, control.FrequencyResponseData):
            variable = "z" if loop.isdtime(strict=True) else "s"
            print(f"  L({variable}): {summary(loop)}")
        ours = r["loopcraft"]
        print(f"  python-control's method: {r['python_control_method']}")
        print(f"  {'':<14}{'python-control':<30}loopcraft ({ours.get('method', 'not given')})")
        theirs = [(db, w) for db, w in zip(r["gain_margins_db"], r["phase_crossovers"]) if db is not None]
        side_by_side("gain margin", "dB", theirs, ours.get("gain", []), loop)
        theirs = list(zip(r["phase_margins_deg"], r["gain_crossovers"]))
        side_by_side("phase margin", "deg", theirs, ours.get("phase", []), loop)
        print(f"  where they differ: {DIFFERS[name]}")
        if name in BREAKS:
            print_breaks(name, r["breaks"], r["multi_loop"], ours)
        for label, sys_z in CONDITIONS[name][2]().items():
            print(f"  {label} in the z-domain:{sys_z}")


if __name__ == "__main__":
    main()
'''

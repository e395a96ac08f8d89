"""`loopcraft export --to python`: a runnable python-control script of a design.

Each flight condition's interconnection is rebuilt entry by entry
(`sessions.export.design_model`): every block a ``control.tf`` (a table's AAA fit a
``control.zpk``, a delay a Pade approximation), junctions
``control.summing_junction``, joined by name with ``control.interconnect``.
The uses of the break signal read an injected loop signal, so the open loop
is ``L = -(break signal)/(loop signal)``; closing it adds the junction
``loop signal = break signal``.  Numbers are written with ``repr`` (the
shortest text that reads back to the same float).  The script prints each
condition's margins (``control.stability_margins``) and closed-loop poles;
``--json`` prints them as JSON.
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
    rows,
    w_to_z,
)

PADE_ORDER = 6


def python_script(d: Design, sample_time: float | None = None) -> str:
    """The whole script (text) of design ``d``; ``sample_time`` labels w-plane designs' z-domain forms."""
    names = identifiers(tuple(c.name for c in d.conditions))
    parts = [_header(d), _parameters(d)]
    for c in d.conditions:
        parts.append(_condition(c, names[c.name], sample_time))
    table = ", ".join(
        f"{c.name!r}: ({names[c.name]}_loop, {names[c.name]}_closed, {names[c.name]}_z)" for c in d.conditions
    )
    parts.append(f"# condition -> (open loop, closed loop, z-domain compensators)\nCONDITIONS = {{{table}}}\n")
    parts.append(MAIN)
    return "\n\n".join(parts)


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


def _condition(c: ExportCondition, name: str, sample_time: float | None) -> str:
    cut = loop_input(c)
    ident = identifiers(c.signals)
    produced = [ident[s] for s, _ in rows(c)]
    inputs = [ident[s] for s in c.inputs]
    lines = [
        f"def {name}_blocks():",
        f'    """Condition {c.name!r} (variable {c.variable}): its blocks and junctions; the uses of '
        f'{c.break_at!r} read the loop signal {cut!r}."""',
        "    return [",
    ]
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
        "",
        "",
    ]
    lines += _z_domain(c, name, sample_time)
    return "\n".join(lines)


def _reads(entry: ExportEntry, c: ExportCondition, cut: str) -> str:
    return cut if entry.input == c.break_at else c.ident(entry.input)


def _row(c: ExportCondition, signal: str, entries: list[ExportEntry], cut: str) -> list[str]:
    """The systems defining one signal: a block, a summing junction, or blocks summed."""
    out = c.ident(signal)
    labels = identifiers(tuple(dict.fromkeys(e.label for e in c.entries)))
    if len(entries) == 1:
        return _system(entries[0], _reads(entries[0], c, cut), out, labels[entries[0].label])
    if is_junction(entries):
        signed = [("-" if e.constant < 0 else "") + _reads(e, c, cut) for e in entries]
        return [f"control.summing_junction(inputs={signed!r}, output={out!r}, name={labels[entries[0].label]!r}),"]
    lines, terms = [], []
    for k, e in enumerate(entries, start=1):
        lines += _system(e, _reads(e, c, cut), f"{out}__{k}", f"{labels[e.label]}__{k}")
        terms.append(f"{out}__{k}")
    return lines + [f"control.summing_junction(inputs={terms!r}, output={out!r}, name={out + '__sum'!r}),"]


def _system(e: ExportEntry, source: str, out: str, name: str) -> list[str]:
    """One entry as a named SISO system, with a comment saying what it is."""
    role = "compensator" if e.compensator else "plant"
    names = f"inputs={source!r}, outputs={out!r}, name={name!r}"
    if e.kind == "delay":
        return [
            f"# {e.label} ({role}): {e.text}, a Pade approximation of order {PADE_ORDER}",
            f"control.tf(*control.pade({e.delay!r}, {PADE_ORDER}), {names}),",
        ]
    if e.kind == "fitted":
        return [
            f"# {e.label} ({role}): AAA fit of {e.text}, degree {e.degree}, residual {e.residual:.3e}",
            f"zpk({list(e.zeros)!r}, {list(e.poles)!r}, {e.gain!r}, {names}),",
        ]
    return [f"# {e.label} ({role}): {e.text}", f"control.tf({list(e.num)!r}, {list(e.den)!r}, {names}),"]


def _z_domain(c: ExportCondition, name: str, sample_time: float | None) -> list[str]:
    """w-plane conditions: each compensator in z by w = (z - 1)/(z + 1)."""
    dt = "True" if sample_time is None else repr(float(sample_time))
    lines = [
        f"def {name}_z():",
        '    """The compensators in the z-domain (w-plane conditions; dt True: sample time unstated)."""',
    ]
    items = []
    if c.variable == "w":
        for e in c.entries:
            if e.compensator and e.kind == "rational":
                numz, denz = w_to_z(e.num, e.den)
                items.append(f"        {e.label!r}: control.tf({numz!r}, {denz!r}, {dt}),")
    lines += ["    return {"] + items + ["    }"]
    return lines


ZPK = '''def zpk(zeros, poles, gain, **names):
    """gain * prod(s - zeros) / prod(s - poles) with real coefficients (conjugate roots)."""
    return control.tf(gain * np.real(np.poly(zeros)), np.real(np.poly(poles)), **names)'''


MAIN = '''def stability_margins(loop):
    """Every crossing control.stability_margins finds (gain margins absolute, phase margins deg)."""
    gm, pm, sm, wpc, wgc, wms = control.stability_margins(loop, returnall=True)
    return {"gain_margins": [float(x) for x in np.atleast_1d(gm)],
            "phase_crossovers": [float(x) for x in np.atleast_1d(wpc)],
            "phase_margins_deg": [float(x) for x in np.atleast_1d(pm)],
            "gain_crossovers": [float(x) for x in np.atleast_1d(wgc)],
            "stability_margins": [float(x) for x in np.atleast_1d(sm)],
            "stability_frequencies": [float(x) for x in np.atleast_1d(wms)]}


def main():
    report = {}
    for name, (loop, closed, _) in CONDITIONS.items():
        found = stability_margins(loop())
        poles = control.poles(closed())
        found["closed_loop_poles"] = [[float(p.real), float(p.imag)] for p in poles]
        found["stable"] = bool(np.all(poles.real < 0))
        report[name] = found
    if "--json" in sys.argv[1:]:
        print(json.dumps(report, indent=2))
        return
    for name, r in report.items():
        print(f"condition {name}: {'stable' if r['stable'] else 'UNSTABLE'} closed loop")
        for gm, w in zip(r["gain_margins"], r["phase_crossovers"]):
            print(f"  gain margin {gm!r} ({20 * np.log10(gm):.6g} dB) at {w!r} rad/s")
        for pm, w in zip(r["phase_margins_deg"], r["gain_crossovers"]):
            print(f"  phase margin {pm!r} deg at {w!r} rad/s")
        for sm, w in zip(r["stability_margins"], r["stability_frequencies"]):
            print(f"  stability margin {sm!r} at {w!r} rad/s")
        for label, sys_z in CONDITIONS[name][2]().items():
            print(f"  {label} in the z-domain:{sys_z}")


if __name__ == "__main__":
    main()
'''

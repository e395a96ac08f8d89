"""`loopcraft analyze`: the margins and closed-loop poles of a loop typed on
the command line (expressions, a state space, a delay, a table), as text or JSON."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from engine.stepping.memory_fields import finite_or_none
from tui.cli.common import CliError
from tui.cli.options import MAX_DELAY

if TYPE_CHECKING:
    from engine.analysis import LoopAnalysis
    from engine.closed_loop.root_locus import RootLocus


def _pair(z: complex) -> list[float]:
    return [float(z.real), float(z.imag)]


def _peak_json(p) -> dict | None:
    return (
        None
        if p is None
        else {
            "value": finite_or_none(p.value),
            "unbounded": p.value == math.inf,
            "db": finite_or_none(p.db),
            "frequency": finite_or_none(p.frequency),
            "at_infinity": p.frequency == math.inf,
            "method": p.method,
            "notes": list(p.notes),
        }
    )


def disk_to_json(d) -> dict | None:
    """The `disk_margin` object of `analyze --json` (None when not computed)."""
    if d is None:
        return None
    return {
        "alpha": d.alpha,
        "skew": d.skew,
        "gain_margin_low": d.gain_low,
        "gain_margin_high": finite_or_none(d.gain_high),
        "gain_margin_low_db": finite_or_none(d.gain_low_db),
        "gain_margin_high_db": finite_or_none(d.gain_high_db),
        "gain_margin_db": finite_or_none(d.gain_db),
        "phase_margin_deg": finite_or_none(d.phase_deg),
        "frequency": finite_or_none(d.frequency),
        "at_infinity": d.frequency == math.inf,
        "method": d.method,
        "notes": list(d.notes),
    }


def locus_to_json(r: RootLocus) -> dict:
    """The `root_locus` object of `analyze --json --locus PARAM`."""
    return {
        "parameter": r.parameter,
        "values": r.values.tolist(),
        "status": r.status,
        "branches": [[_pair(z) for z in r.branches[:, j]] for j in range(r.branches.shape[1])],
        "current_value": r.current_value,
        "current_poles": [_pair(z) for z in r.current],
        "crossings": [{"value": c.value, "frequency": c.frequency, "direction": c.direction} for c in r.crossings],
        "asymptotes": None if r.centroid is None else {"centroid": r.centroid, "angles_deg": list(r.angles_deg)},
        "breakaways": [{"point": _pair(z), "gain": k} for z, k in r.breakaways],
        "notes": list(r.notes),
    }


def analysis_to_json(
    a: LoopAnalysis, variable: str = "s", locus: RootLocus | None = None, sample_time: float | None = None
) -> dict:
    """The documented JSON object of `loopcraft analyze --json` (a loop in z: its sample
    time; poles in z, delay margins in seconds and samples)."""
    m = a.margins
    sampled = variable == "z" and sample_time is not None and a.delay_margin is not None
    samples = a.delay_margin / sample_time if sampled else delay_margin_samples(a) if variable == "w" else None
    return {
        "variable": variable,
        "sample_time": sample_time if variable == "z" else None,
        "gain_margins": [
            {"frequency": g.frequency, "gain_db": finite_or_none(g.gain_db), "distance": g.value} for g in m.listed("G")
        ],
        "phase_margins": [
            {"frequency": p.frequency, "phase_deg": p.phase_deg, "distance": p.value, "delay": finite_or_none(p.delay)}
            for p in m.phase
        ],
        "stability_margins": [{"frequency": s.frequency, "distance": s.value} for s in m.listed("S")],
        "margin_families": [
            {"kind": f.kind, "count": f.count, "from": f.low, "to": f.high, "period": f.period} for f in m.families
        ],
        "crossover_frequency": finite_or_none(m.crossover_frequency),
        "delay_margin": finite_or_none(a.delay_margin),
        "delay_margin_known": a.delay_margin is None or not math.isnan(a.delay_margin),
        "delay_margin_samples": finite_or_none(samples),
        "closed_loop_stable": None if a.verdict == "unknown" else a.verdict == "stable",
        "verdict": a.verdict,
        "closed_loop_poles": None
        if a.closed_loop_poles is None
        else [
            {
                "real": p.value.real,
                "imag": p.value.imag,
                "damping": p.damping,
                "natural_frequency": p.natural_frequency,
                "zeta": p.zeta,
                "wn": p.wn,
                "backward_error": p.backward_error,
                "fixed": h or None,  # "uncontrollable", "unobservable" or both from the loop: a fixed mode
            }
            for p, h in zip(a.closed_loop_poles, a.hidden or ("",) * len(a.closed_loop_poles))
        ],
        "disk_margin": disk_to_json(a.disk_margin),
        "sensitivity_peak": _peak_json(a.sensitivity_peak),
        "complementary_sensitivity_peak": _peak_json(a.complementary_peak),
        **({"root_locus": locus_to_json(locus)} if locus is not None else {}),
        "method": m.label,
        "notes": list(a.notes),
    }


def _delay_text(dm: float | None) -> str:
    """'none' (no crossover: any delay is tolerated), 'not known' (crossovers may lie beyond
    the search: a note says where) or the margin in seconds."""
    if dm is None:
        return "none (no gain crossover: any delay is tolerated)"
    return "not known (gain crossovers may lie beyond the search, see the notes)" if math.isnan(dm) else f"{dm:.6g} s"


def delay_margin_samples(a) -> float | None:
    """A w-plane loop's delay margin in samples: at a gain crossover of
    w-plane frequency nu (w = (z - 1)/(z + 1)), the sampled frequency is
    omega T = 2 atan(nu), and d samples of delay turn the phase by d omega T
    (0 for an unstable closed loop)."""
    if a.verdict == "unstable":
        return 0.0
    m = a.margins
    values = [
        math.radians(p.phase_deg) % (2 * math.pi) / (2 * math.atan(p.frequency)) for p in m.phase if p.frequency > 0
    ]
    return min(values) if values else None


def _cells(*cells: str) -> str:
    """One table line: cells right-aligned in their columns, always two spaces apart."""
    widths = (6, 20, 22, 14)
    return "  ".join(c.rjust(w) if k else c.ljust(w) for k, (c, w) in enumerate(zip(cells, widths))).rstrip()


def _num(x: float | None, unit: str = "", spec: str = ".6g") -> str:
    if x is None or not math.isfinite(x):
        return "inf" if x is not None and x > 0 else ("-inf" if x is not None and x < 0 else "-")
    return f"{x:{spec}}{(' ' + unit) if unit else ''}"


def analysis_to_text(
    a: LoopAnalysis,
    expressions: Sequence[str],
    variable: str = "s",
    delay: float = 0.0,
    sample_time: float | None = None,
) -> str:
    """A readable table of the margins and poles (w-plane frequencies labelled as such; a
    loop in z in rad/s, its delay margin in seconds and samples, its poles in z)."""
    m = a.margins
    unit = "w-plane rad/s" if variable == "w" else "rad/s"
    loop = " * ".join(f"({e})" for e in expressions) + (f" * exp(-{delay:g} s)" if delay else "")
    lines = [f"Open loop GH = {loop}  (unity negative feedback)", ""]
    lines.append(_cells("kind", f"frequency {unit}", "classical", "|1+GH|"))
    for g in m.listed("G"):
        lines.append(_cells("G", _num(g.frequency), _num(g.gain_db, "dB", ".4f"), _num(g.value, spec=".6g")))
    for p in m.phase:
        lines.append(_cells("P", _num(p.frequency), _num(p.phase_deg, "deg", ".4f"), _num(p.value, spec=".6g")))
    for st in m.listed("S"):
        lines.append(_cells("S", _num(st.frequency), "", _num(st.value, spec=".6g")))
    if not m.all():
        lines.append("(no crossings)")
    lines.append("")
    wc, dm = m.crossover_frequency, a.delay_margin
    lines.append(f"crossover frequency: {'none' if wc is None else f'{wc:.6g} {unit}'}")
    if variable == "z":
        lines.append(f"sample time: {sample_time:g} s (Nyquist frequency {math.pi / sample_time:.6g} rad/s)")
        samples = "" if dm is None or math.isnan(dm) else f" ({dm / sample_time:.6g} samples)"
        lines.append(f"delay margin: {_delay_text(dm)}{samples}")
    elif variable == "s":
        lines.append(f"delay margin: {_delay_text(dm)}")
    else:
        samples = delay_margin_samples(a)
        lines.append(f"delay margin: {'none' if samples is None else f'{samples:.6g} samples'}")
    lines.append(f"margins: {m.label}")
    lines.append(f"closed loop: {a.verdict}")
    poles = a.closed_loop_poles or ()
    for p, hidden in zip(poles, a.hidden or ("",) * len(poles)):
        zeta = 0.0 if abs(p.damping) < 5e-13 else p.damping
        where = (
            f"z {p.value.real:+.6g} {p.value.imag:+.6g}j |z| {abs(p.value):.6g}"
            if variable == "z"
            else (f"{p.value.real:+.6g} {p.value.imag:+.6g}j")
        )
        equivalent = " (s-plane equivalent)" if variable == "z" else ""
        fixed = f"   fixed: {hidden} from the loop" if hidden else ""
        lines.append(f"  pole {where}   zeta {zeta:.4f}   wn {p.natural_frequency:.6g} {unit}{equivalent}{fixed}")
    lines.extend(_measure_lines(a, unit))
    lines.extend(f"note: {n}" for n in a.notes)
    lines.extend(f"note: {f.summary}" for f in m.families)
    return "\n".join(lines)


def _at(w: float, unit: str) -> str:
    return "at inf" if w == math.inf else ("" if not math.isfinite(w) else f"at {w:.6g} {unit}")


def _measure_lines(a: LoopAnalysis, unit: str) -> list[str]:
    """The disk margin and sensitivity peaks, one line each."""
    lines = []
    d = a.disk_margin
    if d is not None:
        lines.append(
            f"disk margin (skew {d.skew:g}): alpha {d.alpha:.6g}, gain {_num(d.gain_low_db, 'dB', '.4f')}"
            f" .. {_num(d.gain_high_db, 'dB', '.4f')}, phase {_num(d.phase_deg, 'deg', '.4f')}"
            f" {_at(d.frequency, unit)}".rstrip()
        )
    for name, p in (("sensitivity peak Ms", a.sensitivity_peak), ("complementary peak Mt", a.complementary_peak)):
        if p is not None:
            if math.isfinite(p.value):
                lines.append(f"{name}: {p.value:.6g} ({_num(p.db, 'dB', '.4f')}) {_at(p.frequency, unit)}".rstrip())
            elif a.verdict == "unstable":  # the finite peak on the axis is in the notes, labelled
                lines.append(f"{name}: inf (unbounded)" + "".join(f"; {n}" for n in p.notes))
            else:  # a closed-loop pole on the axis, there
                lines.append(f"{name}: inf (unbounded) {_at(p.frequency, unit)}".rstrip())
    return lines


def locus_to_text(r: RootLocus) -> str:
    """A short text summary of a root locus: range, status, crossings, asymptotes, breakaways."""
    lines = [
        f"root locus in {r.parameter}: {r.values[0]:.6g} .. {r.values[-1]:.6g}, {r.values.size} points, "
        f"{r.branches.shape[1]} branches ({r.status})"
    ]
    for c in r.crossings:
        lines.append(
            f"  imaginary-axis crossing: {r.parameter} = {c.value:.10g} at {c.frequency:.6g} rad/s "
            f"({'into' if c.direction > 0 else 'out of'} the right half-plane)"
        )
    if r.centroid is not None:
        lines.append(f"  asymptotes: centroid {r.centroid:.6g}, angles {', '.join(f'{x:g}' for x in r.angles_deg)} deg")
    for z, k in r.breakaways:
        lines.append(f"  breakaway: {z.real:+.6g} {z.imag:+.6g}j at gain {k:.6g}")
    lines.extend(f"  note: {n}" for n in r.notes)
    return "\n".join(lines)


def _check_delay(network, params: dict[str, float]) -> None:
    """The loop's whole delay (--delay and exp(-T*s) factors) within `MAX_DELAY`, as --delay's."""
    from engine.loop.responses import network_delay

    tau = network_delay(network, params)
    if tau > MAX_DELAY:
        raise CliError(
            f"--tf: the loop's delay, {tau:g} s (--delay and exp(-T*s) factors), is over the limit of {MAX_DELAY:g} s"
        )


def _table_loop(args: argparse.Namespace):
    """The network and grid of `analyze --table`: the table (times any --tf
    expressions) with unity negative feedback, on the table's own frequencies."""
    from pydantic import ValidationError

    from engine.analysis import unity_feedback
    from sessions.build import frequency_table
    from sessions.format.checks import invalid_what
    from sessions.format.schema import TableModel

    path = Path(args.table)
    try:
        model = TableModel(unit=args.unit, form=args.form, gain=args.gain, csv=path.name, columns=args.columns)
    except ValidationError as exc:
        raise CliError(f"--table: {invalid_what(exc)}") from None
    table = frequency_table(model, "table", path.parent)
    network = unity_feedback(args.tf or ["1"], args.variable, args.delay, table=table)
    return network, table.omega


def _state_space_file(args: argparse.Namespace) -> dict:
    """The matrices of the `--ss` file."""
    from sessions.format.state_space_files import read_matrices

    return read_matrices(Path(args.ss), f"--ss {args.ss}")


def _several_loops(m: dict) -> bool:
    """Whether the --ss model has more than one input or output (a multi-loop plant)."""
    from engine.multiloop.plant import input_count

    return input_count(m["B"], m["C"]) != (1, 1)


def _state_space_loop(args: argparse.Namespace, m: dict):
    """The network of `analyze --ss`: the state space in the file (times any --tf
    expressions, a delay) with unity negative feedback, kept as state space."""
    from engine.analysis import unity_feedback
    from engine.model.blocks import StateSpaceTransfer

    if args.break_name is not None or args.simultaneous:
        what = f"--break {args.break_name}" if args.break_name is not None else "--simultaneous"
        raise CliError(f"{what}: the --ss model has one input and one output (one loop, at e)")
    path = Path(args.ss)
    plant = StateSpaceTransfer(m["A"], m["B"], m["C"], m["D"], f"--ss {path.name}")
    return unity_feedback(args.tf or ["1"], args.variable, args.delay, state_space=plant)


def cmd_analyze(args: argparse.Namespace) -> int:
    """Analyze the loop the options describe; print text or JSON."""
    import numpy as np

    from engine.analysis import analyze, unity_feedback

    if args.file is not None:
        return _session_design(args)
    if args.table is not None and args.ss is not None:
        raise CliError("give --ss FILE or --table FILE.csv, not both")
    if args.simultaneous and args.ss is None:
        raise CliError("--simultaneous: the simultaneous margins of a multi-loop --ss plant (m inputs and m outputs)")
    if args.break_name is not None and args.ss is None:
        raise CliError(
            f"--break {args.break_name}: a loop break of a multi-loop --ss plant or of a session (FILE.json); "
            "a loop typed with --tf or --table is broken at e"
        )
    if args.table is not None:
        network, omega = _table_loop(args)
    elif args.ss is not None:
        matrices = _state_space_file(args)
        if _several_loops(matrices):
            return _multi_loop(args, matrices)
        network = _state_space_loop(args, matrices)
        omega = np.geomspace(args.wmin, args.wmax, args.points)
    elif args.variable == "z" and (args.tf or args.held):
        if args.delay and not args.held:
            raise CliError("--delay with --variable z: a delay of k samples is a factor z^-k of a --tf expression")
        network = unity_feedback([*(args.tf or []), *_held(args)], "z")
        omega = np.geomspace(args.wmin, args.wmax, args.points)
    elif not args.tf:
        raise CliError("give --tf EXPR (repeatable), --ss FILE or --table FILE.csv")
    else:
        network = unity_feedback(args.tf, args.variable, args.delay)
        omega = np.geomspace(args.wmin, args.wmax, args.points)
    params = _params(args.param or [])
    missing = [name for name in network.parameters if name not in params]
    if missing:
        raise CliError(
            f"--tf: unknown name(s) {', '.join(missing)} (expressions for analyze "
            f"take numbers, the variable {args.variable!r}, delay factors exp(-T*s) "
            "and names given by --param NAME=VALUE)"
        )
    if args.sample_time is not None and args.variable != "z":
        raise CliError("--sample-time is a loop in z's: give --variable z (and the loop in z)")
    _check_delay(network, params)
    with np.errstate(all="ignore"):  # a typed loop's extreme numbers: said by the results, never warned about
        if args.variable == "z":
            result = _sampled(args, network, omega, params)
            locus = None
        else:
            result = analyze(network, "e", omega, params, skew=args.skew)
            locus = _locus(args, network, params)
    if args.json:
        print(json.dumps(analysis_to_json(result, args.variable, locus, args.sample_time), indent=2, sort_keys=True))
    else:
        shown = ([f"table {args.table}"] if args.table else []) + list(args.tf or [])
        shown += [f"state space {args.ss}"] if args.ss else []
        print(analysis_to_text(result, shown, args.variable, args.delay, args.sample_time))
        if locus is not None:
            print(locus_to_text(locus))
    return 0


def _multi_loop_refused(args: argparse.Namespace) -> str | None:
    """The option a multi-loop --ss plant does not take with it, said (None: none given)."""
    given = [
        ("--tf", args.tf),
        ("--delay", args.delay),
        ("--locus", args.locus),
        ("--param", args.param),
        ("--held", args.held),
        ("--variable w", args.variable == "w"),
    ]
    named = [name for name, value in given if value]
    return ", ".join(named) or None


def _multi_loop(args: argparse.Namespace, m: dict) -> int:
    """`analyze --ss FILE` of a square plant of m > 1 inputs and outputs: every break (or the one
    --break names) loop at a time, and all together (the multi-loop disk margin)."""
    import numpy as np

    from engine.multiloop.loops import analyze_breaks
    from engine.multiloop.plant import checked_plant

    refused = _multi_loop_refused(args)
    if refused:
        raise CliError(f"--ss {args.ss}: a multi-loop plant (unity feedback at its inputs) takes no {refused}")
    where = f"--ss {Path(args.ss).name}"
    plant = checked_plant(m["A"], m["B"], m["C"], m["D"], where)
    if args.break_name is not None and args.break_name not in plant.names:
        raise CliError(f"--break {args.break_name!r}: the plant's breaks are {', '.join(plant.names)}")
    breaks = None if args.break_name is None else [args.break_name]
    omega, T = _multi_loop_grid(args)
    if args.simultaneous and (T is not None or breaks is not None):
        raise CliError("--simultaneous: every loop of a plant in s at once (not with --break or --variable z)")
    with np.errstate(all="ignore"):
        result = analyze_breaks(plant, omega, breaks, args.skew, breaks is None, where, T, args.simultaneous)
    if args.json:
        print(json.dumps(loops_to_json(result, args.variable, T), indent=2, sort_keys=True))
    else:
        print(loops_to_text(result, args.ss, args.variable, T))
    return 0


def _multi_loop_grid(args: argparse.Namespace):
    """(the plot grid, the sample time or None) of a multi-loop plant: in z, up to the Nyquist frequency."""
    import numpy as np

    if args.variable != "z":
        if args.sample_time is not None:
            raise CliError("--sample-time is a loop in z's: give --variable z (and the plant in z)")
        return np.geomspace(args.wmin, args.wmax, args.points), None
    T = args.sample_time
    if T is None or not (math.isfinite(T) and T > 0):
        raise CliError("--variable z needs --sample-time T (seconds, finite, > 0): the frequencies are in rad/s")
    nyquist = math.pi / T
    return np.geomspace(min(args.wmin, 1e-3 * nyquist), nyquist * (1 - 1e-9), args.points), T


def multi_loop_to_json(d) -> dict | None:
    """The `multi_loop_disk_margin` object of `analyze --json` of a multi-loop plant."""
    if d is None:
        return None
    return {
        "alpha": d.alpha,
        "alpha_lower": d.alpha_lower,
        "alpha_upper": finite_or_none(d.alpha_upper),
        "gap": d.gap,
        "skew": d.skew,
        "frequency": finite_or_none(d.frequency),
        "at_infinity": d.frequency == math.inf,
        "gain_margin_low": d.gain_low,
        "gain_margin_high": finite_or_none(d.gain_high),
        "gain_margin_low_db": finite_or_none(d.gain_low_db),
        "gain_margin_high_db": finite_or_none(d.gain_high_db),
        "gain_margin_db": finite_or_none(d.gain_db),
        "phase_margin_deg": finite_or_none(d.phase_deg),
        "perturbation": [_pair(z) for z in d.delta],
        "status": d.status,
        "certified": d.status == "certified",
        "intervals": d.intervals,
        "method": d.method,
        "notes": list(d.notes),
    }


def loops_to_json(result, variable: str = "s", sample_time: float | None = None) -> dict:
    """The JSON object of `analyze --ss FILE --json` for a multi-loop plant: ``loops`` (one object
    per break: its name and the keys of one loop's analysis) and ``multi_loop_disk_margin``."""
    return {
        "variable": variable,
        "sample_time": sample_time,
        "breaks": [name for name, _ in result.loops],
        "loops": [{"name": name, **analysis_to_json(a, variable, sample_time=sample_time)} for name, a in result.loops],
        "multi_loop_disk_margin": multi_loop_to_json(result.together),
        "simultaneous_margins": None
        if result.gain_only is None
        else {kind: _simultaneous_json(m) for kind, m in (("gain", result.gain_only), ("phase", result.phase_only))},
    }


def _simultaneous_json(m) -> dict:
    return {
        "lower": finite_or_none(m.lower),
        "upper": finite_or_none(m.upper),
        "unit": "dB" if m.kind == "gain" else "deg",
        "perturbation": list(m.perturbation),
        "frequency": finite_or_none(m.frequency),
        "status": m.status,
    }


def loops_to_text(result, source: str, variable: str = "s", sample_time: float | None = None) -> str:
    """Each loop's table (`analysis_to_text`) under its break's name, then the multi-loop disk margin."""
    parts = []
    for name, a in result.loops:
        shown = [f"loop broken at {name} of {source}, every other loop closed"]
        parts.append(analysis_to_text(a, shown, variable, 0.0, sample_time))
        parts.append("")
    d = result.together
    if d is not None:
        parts.append(
            f"multi-loop disk margin (skew {d.skew:g}, every break at once): alpha {d.alpha:.6g} "
            f"in [{d.alpha_lower:.9g}, {d.alpha_upper:.9g}] ({d.status}), gain {_num(d.gain_low_db, 'dB', '.4f')}"
            f" .. {_num(d.gain_high_db, 'dB', '.4f')}, phase {_num(d.phase_deg, 'deg', '.4f')} {_at(d.frequency, 'rad/s')}"
        )
        parts.extend(f"note: {n}" for n in d.notes)
    for m in (result.gain_only, result.phase_only):
        if m is not None:
            unit = "dB" if m.kind == "gain" else "deg"
            parts.append(
                f"simultaneous {m.kind}-only margin: +-{_num(m.lower, unit, '.6g')} guaranteed, "
                f"destabilized at +-{_num(m.upper, unit, '.6g')} ({m.status})"
            )
    return "\n".join(parts).rstrip()


def _sampled(args: argparse.Namespace, network, omega, params):
    """`analyze --variable z --sample-time T`: the loop in z through the w-plane
    (`engine.loop.sampled`), its grid up to the Nyquist frequency."""
    import numpy as np

    from engine.loop.sampled import analyze_sampled

    T = args.sample_time
    if T is None:
        raise CliError("--variable z needs --sample-time T (seconds): the frequencies are reported in rad/s")
    if args.table is not None:
        raise CliError(
            "--variable z: give the loop as --tf expressions in z or --ss (in z), and --held expressions in s"
        )
    if not (math.isfinite(T) and T > 0):
        raise CliError(f"--sample-time {T!r}: a finite number of seconds > 0")
    nyquist = math.pi / T
    omega = np.geomspace(min(args.wmin, 1e-3 * nyquist), nyquist * (1 - 1e-9), args.points)
    return analyze_sampled(network, "e", omega, params, T, skew=args.skew)


def _held(args: argparse.Namespace) -> list[str]:
    """The --held continuous blocks (expressions in s) discretized by --discretize (zero-order
    hold by default, --delay taken as whole and fractional samples): polynomials in z."""
    from engine.analysis import split_delays
    from engine.errors import EngineError
    from engine.model.discretize import discretized_text

    if args.held and args.sample_time is None:
        raise CliError("--variable z needs --sample-time T (seconds): the frequencies are reported in rad/s")
    if args.delay and args.discretize != "zoh":
        raise CliError(f"--delay: a delay is discretized with its hold (--discretize zoh), not by {args.discretize}")
    out = []
    for text in args.held or []:
        try:
            if split_delays(text)[1]:
                raise CliError(f"--held {text!r}: give its delay exp(-T*s) as --delay T (held with the block)")
            out.append(discretized_text(text, args.sample_time, args.discretize, args.delay))
        except EngineError as exc:
            raise CliError(f"--held {text!r}: {exc}") from None
    return out


def _session_design(args: argparse.Namespace) -> int:
    """`analyze FILE.json`: the loop of a session's current design (the last iteration's,
    else the start) in one flight condition, as text or JSON."""
    from engine.analysis import analyze
    from engine.design.compensator_items import compensators
    from engine.design.compensator_items import named as item_names
    from engine.stepping.protocol import StepRecord
    from tui.cli.common import load

    if args.tf or args.table is not None or args.ss is not None:
        raise CliError("FILE.json analyzes a session's loop: give it, or --tf/--ss/--table, not both")
    session = load(args.file)
    problem, model = session.problem, session.model
    names = [c.name for c in problem.conditions]
    if not names:
        raise CliError(f"{args.file}: the session has no loop (no flight condition)")
    if args.condition is not None and args.condition not in names:
        raise CliError(f"--condition {args.condition!r}: the session's conditions are {', '.join(names)}")
    k = names.index(args.condition) if args.condition is not None else 0
    at = model.current_iteration
    named = StepRecord.from_json(model.records[at - 1]).parameters if at else None
    c = problem.conditions[k]
    values = problem.condition_values(k, named=named)
    break_at = c.break_at if args.break_name is None else args.break_name
    if break_at not in c.network.signals:
        raise CliError(f"--break {break_at!r}: {c.name}'s signals are {', '.join(c.network.signals)}")
    if args.break_name is not None and not c.network.on_a_loop(break_at):
        raise CliError(f"--break {break_at!r}: the signal lies on no loop of {c.name}'s diagram (it opens no loop)")
    result = analyze(c.network, break_at, problem.grid.omega, values)
    every = list(c.breaks) if args.break_name is None and tuple(c.breaks) not in ((), (c.break_at,)) else []
    others = [(b, analyze(c.network, b, problem.grid.omega, values)) for b in every]
    together, refused = _diagram_together(c, every, values) if len(every) > 1 else (None, None)
    parts = compensators(c.network, values)
    T = c.network.sample_time
    variable = "z" if T is not None else c.network.variable
    if args.json:
        out = analysis_to_json(result, variable, sample_time=T) | {
            "compensators": {
                name: [_item_json(i) | {"name": n} for n, i in zip(item_names(found), found)]
                for name, found in parts.items()
            }
        }
        if others:
            out["loops"] = [{"name": b, **analysis_to_json(r, variable, sample_time=T)} for b, r in others]
            out["multi_loop_disk_margin"] = multi_loop_to_json(together)
            if refused is not None:
                out["multi_loop_disk_margin_refused"] = refused
        print(json.dumps(out, indent=2, sort_keys=True))
    else:
        design = f"iteration {at}" if at else "the start"
        print(analysis_to_text(result, [f"{c.name} at {break_at}, {design} of {args.file}"], variable, 0.0, T))
        for b, r in (found for found in others if found[0] != break_at):  # the primary break is above
            print("\n" + analysis_to_text(r, [f"{c.name} at {b} (breaks), {design} of {args.file}"], variable, 0.0, T))
        if together is not None:
            from engine.multiloop.loops import LoopsAnalysis

            print("\n" + loops_to_text(LoopsAnalysis((), together), args.file))
        for name, found in parts.items():
            lines = [
                f"  {name}.{item_name}: {i.reading(c.network.sample_time)}"
                for item_name, i in zip(item_names(found), found)
            ]
            print(f"compensator {name}:\n" + "\n".join(lines))
    return 0


def _diagram_together(c, breaks: list[str], values):
    """(the multi-loop disk margin at a condition's breaks, None) or (None, why not: also a note on standard
    error) when it is not computed (tables, delays: named)."""
    from engine.errors import EngineError
    from engine.multiloop.network_breaks import diagram_disk_margin

    try:
        return diagram_disk_margin(c.network, breaks, values), None
    except EngineError as exc:
        print(f"note: {c.name}: no multi-loop disk margin at its breaks: {exc}", file=sys.stderr)
        return None, str(exc)


def _item_json(item) -> dict:
    w = abs(item.root)
    return {
        "kind": item.kind,
        "value": item.root.real if item.kind == "gain" else None,
        "root": None if item.kind == "gain" else _pair(item.root),
        "frequency": None if item.kind == "gain" else w,
        "zeta": -item.root.real / w if item.kind.endswith("pair") and w else None,
        "parameters": list(item.parameters),
    }


def _params(items: Sequence[str]) -> dict[str, float]:
    """--param NAME=VALUE options as a mapping."""
    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not sep or not name.strip().isidentifier() or not math.isfinite(value):
            raise CliError(f"--param: expected NAME=VALUE with a finite number, not {item!r}")
        out[name.strip()] = value
    return out


def _locus(args: argparse.Namespace, network, params: dict[str, float]):
    """The root locus --locus asks for (None without it)."""
    if args.locus is None:
        return None
    from engine.closed_loop.root_locus import root_locus

    return root_locus(
        network,
        "e",
        params,
        args.locus,
        None if args.locus_range is None else tuple(args.locus_range),
        args.locus_points,
    )


def add_parser(sub) -> None:
    """The `analyze` subcommand and its options."""
    p = sub.add_parser(
        "analyze", help="margins and closed-loop poles of a unity-feedback loop, or of a session's current design"
    )
    p.add_argument("file", nargs="?", metavar="FILE.json", help="a session: the loop of its current design")
    p.add_argument("--condition", metavar="NAME", help="FILE.json: the flight condition (default: the first)")
    p.add_argument(
        "--tf",
        action="append",
        metavar="EXPR",
        help="a transfer function, e.g. '16000/(s*(s+8)*(s+20))'; repeat to multiply",
    )
    p.add_argument(
        "--table",
        metavar="FILE.csv",
        help="a tabulated open loop (times any --tf): margins refined on a rational fit, its residual stated",
    )
    p.add_argument(
        "--ss",
        metavar="FILE",
        help="a state-space plant (times any --tf): a .npz with arrays A, B, C, D or a .json with those keys, "
        "kept as state space (no polynomial is multiplied out)",
    )
    p.add_argument(
        "--break",
        dest="break_name",
        metavar="NAME",
        help="--ss with several inputs: the one loop break to report (u1, u2, ...: the plant's inputs)",
    )
    p.add_argument(
        "--simultaneous",
        action="store_true",
        help="--ss with several inputs: also the simultaneous gain-only and phase-only margins (bracketed)",
    )
    p.add_argument(
        "--columns",
        nargs="+",
        metavar="NAME",
        help="--table: frequency and value column names (three, two for --form magnitude)",
    )
    p.add_argument(
        "--form",
        default="polar",
        choices=["polar", "db", "cartesian", "magnitude"],
        help="--table: magnitude (linear) and phase (deg), magnitude in dB and phase (deg), real and imaginary, "
        "or magnitude only",
    )
    p.add_argument("--unit", default="rad/s", choices=["rad/s", "hz"], help="--table: unit of its frequencies")
    p.add_argument("--gain", type=float, default=1.0, help="--table: a gain its values are multiplied by")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument(
        "--variable",
        default="s",
        choices=["s", "w", "z"],
        help="frequency variable (w: w-plane; z: with --sample-time)",
    )
    p.add_argument(
        "--held",
        action="append",
        metavar="EXPR",
        help="a loop in z: a continuous block (in s, numbers only) discretized by --discretize (repeatable)",
    )
    p.add_argument(
        "--discretize",
        choices=["zoh", "tustin", "matched"],
        default="zoh",
        help="how --held blocks are discretized (default zoh: exact, with --delay as whole and fractional samples)",
    )
    p.add_argument(
        "--sample-time",
        type=float,
        metavar="T",
        help="a loop in z: its sample time, s (frequencies in rad/s up to the Nyquist frequency pi/T)",
    )
    p.add_argument(
        "--delay",
        type=float,
        default=0.0,
        metavar="T",
        help="a loop delay exp(-T s) in seconds (also written as a factor exp(-T*s) in --tf)",
    )
    p.add_argument("--wmin", type=float, default=1e-3, help="plot grid start, rad/s (margins do not depend on it)")
    p.add_argument("--wmax", type=float, default=1e3, help="plot grid end, rad/s")
    p.add_argument("--points", type=int, default=400, help="plot grid points")
    p.add_argument(
        "--param",
        action="append",
        metavar="NAME=VALUE",
        help="a value for a name in the expressions (repeatable), e.g. for --locus NAME",
    )
    p.add_argument("--skew", type=float, default=0.0, help="disk margin skew (0 balanced, 1: S, -1: T)")
    p.add_argument("--locus", metavar="PARAM", help="add the root locus in the loop gain ('gain') or a --param name")
    p.add_argument(
        "--locus-range",
        type=float,
        nargs=2,
        metavar=("LO", "HI"),
        help="--locus: the range of the gain or parameter (default: decades around it)",
    )
    p.add_argument("--locus-points", type=int, default=2000, help="--locus: most points of the locus")
    p.set_defaults(handler=cmd_analyze)

"""The `loopcraft` command line: headless analysis (and, later, the app)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence

import numpy as np

from engine.analysis import LoopAnalysis, analyze, unity_feedback
from engine.errors import EngineError


class CliError(Exception):
    """Bad input on the command line: printed as one line, exit status 2."""


def _number(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def analysis_to_json(a: LoopAnalysis) -> dict:
    """The documented JSON object of `loopcraft analyze --json`."""
    m = a.margins
    return {
        "gain_margins": [{"frequency": g.frequency, "gain_db": _number(g.gain_db), "distance": g.value}
                         for g in m.gain],
        "phase_margins": [{"frequency": p.frequency, "phase_deg": p.phase_deg, "distance": p.value,
                           "delay": _number(p.delay)} for p in m.phase],
        "stability_margins": [{"frequency": s.frequency, "distance": s.value} for s in m.stability],
        "crossover_frequency": _number(m.crossover_frequency),
        "delay_margin": _number(m.delay_margin),
        "closed_loop_stable": None if a.verdict == "unknown" else a.verdict == "stable",
        "verdict": a.verdict,
        "closed_loop_poles": None if a.closed_loop_poles is None else [
            {"real": p.value.real, "imag": p.value.imag, "damping": p.damping,
             "natural_frequency": p.natural_frequency} for p in a.closed_loop_poles],
        "method": m.method,
        "notes": list(a.notes),
    }


def analysis_to_text(a: LoopAnalysis, expressions: Sequence[str]) -> str:
    """A readable table of the margins and poles."""
    m = a.margins
    lines = [f"Open loop GH = {' * '.join(f'({e})' for e in expressions)}  (unity negative feedback)", ""]
    lines.append(f"{'kind':<6}{'frequency rad/s':>18}{'classical':>16}{'|1+GH|':>12}")
    for g in m.gain:
        lines.append(f"{'G':<6}{g.frequency:>18.6g}{g.gain_db:>12.4f} dB{g.value:>12.5f}")
    for p in m.phase:
        lines.append(f"{'P':<6}{p.frequency:>18.6g}{p.phase_deg:>11.4f} deg{p.value:>12.5f}")
    for s in m.stability:
        lines.append(f"{'S':<6}{s.frequency:>18.6g}{'':>16}{s.value:>12.5f}")
    if not m.all():
        lines.append("(no crossings)")
    lines.append("")
    wc, dm = m.crossover_frequency, m.delay_margin
    lines.append(f"crossover frequency: {'none' if wc is None else f'{wc:.6g} rad/s'}")
    lines.append(f"delay margin: {'none' if dm is None else f'{dm:.6g} s'}")
    lines.append(f"closed loop: {a.verdict}")
    for p in a.closed_loop_poles or ():
        lines.append(f"  pole {p.value.real:+.6g} {p.value.imag:+.6g}j   zeta {p.damping:.4f}"
                     f"   wn {p.natural_frequency:.6g} rad/s")
    lines.extend(f"note: {n}" for n in a.notes)
    return "\n".join(lines)


def cmd_analyze(args: argparse.Namespace) -> int:
    network = unity_feedback(args.tf, args.variable)
    omega = np.geomspace(args.wmin, args.wmax, args.points)
    missing = network.parameters
    if missing:
        raise CliError(f"--tf: unknown name(s) {', '.join(missing)} (expressions for analyze "
                       f"take numbers and the variable {args.variable!r} only)")
    result = analyze(network, "e", omega, {})
    if args.json:
        print(json.dumps(analysis_to_json(result), indent=2, sort_keys=True))
    else:
        print(analysis_to_text(result, args.tf))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="loopcraft", description="Classical compensator design workbench.")
    sub = parser.add_subparsers(dest="command")
    p = sub.add_parser("analyze", help="margins and closed-loop poles of a unity-feedback loop")
    p.add_argument("--tf", action="append", required=True, metavar="EXPR",
                   help="a transfer function, e.g. '16000/(s*(s+8)*(s+20))'; repeat to multiply")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--variable", default="s", choices=["s", "w"], help="frequency variable (w: w-plane)")
    p.add_argument("--wmin", type=float, default=1e-3, help="plot grid start, rad/s (margins do not depend on it)")
    p.add_argument("--wmax", type=float, default=1e3, help="plot grid end, rad/s")
    p.add_argument("--points", type=int, default=400, help="plot grid points")
    p.set_defaults(handler=cmd_analyze)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return args.handler(args)
    except (EngineError, CliError) as exc:
        print(f"loopcraft {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

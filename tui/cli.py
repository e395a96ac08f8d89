"""The `loopcraft` command line: headless analysis (and, later, the app)."""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

from engine.algorithm import MeasureRow, StepRecord, make_settings
from engine.errors import EngineError
from engine.measures import tableau
from engine.qcg.setup import cascade_problem
from engine.qcg.tradeoff import penalty_sweep
from sessions.errors import SessionError
from sessions.runner import adopt_design, replay, run_session, set_setting
from sessions.store import Session, autosave_candidate, load_session, save_session

from .cip_report import cip_report_text
from .qcg_report import qcg_report_text
from . import analyze_cli, sweep_cli
from .cli_common import CliError, finite_or_none
from .slp_report import slp_report_text


EXAMPLES = Path(__file__).resolve().parent.parent / "sessions" / "examples"


def tableau_text(rows: Sequence[MeasureRow]) -> str:
    """The report-000 style table: number, kind, value, frequency, desired value."""
    lines = [f"{'no.':>4} {'name':<5} {'kind':<20} {'condition':<12} {'value':>12} {'frequency':>12} "
             f"{'desired':>10}  met  method"]
    for n, r in enumerate(rows, start=1):
        freq = "" if r.frequency is None else f"{r.frequency:.6g}"
        desired = "" if r.target is None else f"{r.target:.6g}"
        lines.append(f"{n:>4} {r.name:<5} {r.kind:<20} {r.condition:<12} {r.value:>12.6g} {freq:>12} "
                     f"{desired:>10}  {'yes' if r.satisfied else 'NO ':<3}  {r.method or ''}".rstrip())
    return "\n".join(lines)


def _rows_now(session: Session, iteration: int | None = None) -> tuple[list[MeasureRow], StepRecord | None]:
    records = session.records[:session.model.current_iteration]
    if iteration is None:
        iteration = len(records)
    if not 0 <= iteration <= len(records):
        raise CliError(f"--iteration: {iteration} is outside 0..{len(records)}")
    if iteration == 0:
        initial = _initial_record(session, required=False)  # the algorithm's own iteration 0, if it has one
        if initial is not None:
            return list(initial.measures), None
        try:
            return tableau(session.problem), None
        except EngineError as exc:
            raise CliError(f"initial tableau: {exc}") from None
    record = records[iteration - 1]
    return list(record.measures), record


def _summary_json(session: Session) -> dict:
    rows, record = _rows_now(session)
    return {
        "algorithm": session.model.algorithm.name,
        "status": "not started" if record is None else record.status.value,
        "iterations": session.model.current_iteration,
        "parameters": session.problem.named_values() if record is None else dict(record.parameters),
        "objective": None if record is None else record.objective,
        "measures": [{"name": r.name, "kind": r.kind, "condition": r.condition, "value": finite_or_none(r.value),
                      "target": r.target, "satisfied": r.satisfied, "frequency": finite_or_none(r.frequency)}
                     for r in rows],
        "counters": {} if record is None else dict(record.counters),
    }


def _load(file: str) -> Session:
    """Load a session; say so when a newer autosave sits beside it."""
    session = load_session(file)
    for message in session.messages:
        print(f"note: {message}", file=sys.stderr)
    autosave = autosave_candidate(file)
    if autosave is not None:
        print(f"note: {autosave.name} is newer than {Path(file).name}; open it to recover unsaved work",
              file=sys.stderr)
    return session


def cmd_run(args: argparse.Namespace) -> int:
    session = _load(args.file)
    if args.adopt:
        adopt_design(session)
    for assignment in args.set or ():
        set_setting(session, assignment)
    if args.algorithm:
        session.model.algorithm.name = args.algorithm
        session.model.algorithm.settings = {}
        session.model.current_iteration = 0
        session.model.state = None
    show = sys.stderr.isatty() and not args.json

    def progress(record: StepRecord) -> None:
        if show:
            print(f"\riteration {record.iteration}: {record.status.value}"
                  + ("" if record.objective is None else f", objective {record.objective:.6g}"),
                  end="", file=sys.stderr, flush=True)

    run_session(session, None if args.until_done else args.iterations, args.until_done, progress)
    if show:
        print(file=sys.stderr)
    save_session(session, args.out or args.file)
    if args.json:
        print(json.dumps(_summary_json(session), indent=2, sort_keys=True))
    else:
        rows, record = _rows_now(session)
        status = "not started" if record is None else record.status.value
        print(f"{session.model.algorithm.name}: iteration {session.model.current_iteration}, {status}")
        print(tableau_text(rows))
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    result = replay(_load(args.file))
    print(result.message, file=sys.stdout if result.ok else sys.stderr)
    return 0 if result.ok else 1


def cmd_report(args: argparse.Namespace) -> int:
    session = _load(args.file)
    rows, record = _rows_now(session, args.iteration)
    if args.format == "json":
        data = _summary_json(session) if args.iteration is None else {
            "iteration": args.iteration, "measures": [dict(vars(r)) for r in rows]}
        print(json.dumps(data, indent=2, sort_keys=True, default=finite_or_none))
    elif args.format == "csv":
        writer = csv.writer(sys.stdout)
        writer.writerow(["name", "kind", "condition", "value", "frequency", "target", "satisfied", "method"])
        for r in rows:
            writer.writerow([r.name, r.kind, r.condition, repr(r.value), r.frequency, r.target, r.satisfied,
                             r.method or ""])
    elif session.model.algorithm.name == "qcg" and record is not None:
        params = {k: float(v[0] if isinstance(v, list) else v) for k, v in record.parameters.items()}
        try:
            response = cascade_problem(session.problem).frequency_response(params)
        except EngineError as exc:
            raise CliError(f"frequency response: {exc}") from None
        print(qcg_report_text(record, response))
    elif session.model.algorithm.name == "cip":
        print(cip_report_text(record if record is not None else _initial_record(session)))
    elif session.model.algorithm.name == "slp":
        print(slp_report_text(record if record is not None else _initial_record(session)))
    else:
        print(tableau_text(rows))
    return 0


def _initial_record(session: Session, required: bool = True) -> StepRecord | None:
    """Iteration 0: the initial tableau (for cip, the report's Table 1; for
    projection, the untrimmed open loop); None when not ``required`` and the
    algorithm gives none."""
    from .workbench import Workbench
    bench = Workbench(session)
    try:
        bench.ensure_algorithm()
    except SessionError as exc:
        raise CliError(f"initial tableau: {exc}") from None
    record = bench.initial_record()
    if record is None and required:
        raise CliError("initial tableau: the algorithm gives none")
    return record


def cmd_tradeoff(args: argparse.Namespace) -> int:
    """Report 001's penalty sweep: one optimized design per penalty value."""
    session = _load(args.file)
    if session.model.algorithm.name != "qcg":
        raise CliError(f"tradeoff: {args.file} uses {session.model.algorithm.name!r}; the sweep needs a qcg session")
    settings = make_settings("qcg", session.model.algorithm.settings)
    try:
        points = penalty_sweep(session.problem, settings, args.penalty, args.values)
    except EngineError as exc:
        raise CliError(str(exc)) from None
    if args.json:
        print(json.dumps([vars(p) for p in points], indent=2, sort_keys=True, default=finite_or_none))
        return 0
    names = list(points[0].parameters) if points else []
    print(f"{args.penalty:>10} {'x1^2 (N)':>10} {'x1dot^2 (N)':>12} {'u^2':>12} {'udot^2':>12} {'C':>12}  "
          + " ".join(f"{n:>10}" for n in names) + "  status")
    for p in points:
        a = p.averaged_squares
        print(f"{p.penalty:>10.4g} {a['x1_normalized']:>10.4f} {a['x1_rate_normalized']:>12.4f} {a['u']:>12.5g} "
              f"{a['u_rate']:>12.5g} {p.cost:>12.6g}  " + " ".join(f"{p.parameters[n]:>10.5g}" for n in names)
              + f"  {p.status}")
    return 0


def cmd_examples(args: argparse.Namespace) -> int:
    files = sorted(EXAMPLES.glob("*.json"))
    for f in files:
        notes = json.loads(f.read_text()).get("notes", "")
        print(f"{f.name}: {notes.split('. ')[0]}")
    if args.copy:
        target = Path(args.copy)
        target.mkdir(parents=True, exist_ok=True)
        for f in EXAMPLES.iterdir():
            if f.suffix in (".json", ".csv"):
                shutil.copy2(f, target / f.name)
        print(f"copied {len(files)} example(s) to {target}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="loopcraft", description="Classical compensator design workbench. Without a command: the app "
        "(loopcraft [FILE.json] | loopcraft --example NAME).")
    sub = parser.add_subparsers(dest="command")
    analyze_cli.add_parser(sub)
    p = sub.add_parser("run", help="run a session's algorithm and save its records")
    p.add_argument("file")
    p.add_argument("--algorithm", help="switch to this algorithm (restarts from iteration 0)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--iterations", type=int, default=1, metavar="N")
    group.add_argument("--until-done", action="store_true")
    p.add_argument("--out", help="save here instead of in place")
    p.add_argument("--json", action="store_true")
    p.add_argument("--adopt", action="store_true",
                   help="start from the current iteration's parameters (records are cleared)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="set an algorithm setting (restarts from iteration 0); repeatable")
    p.set_defaults(handler=cmd_run)
    p = sub.add_parser("replay", help="re-run a session and compare every recorded iteration")
    p.add_argument("file")
    p.set_defaults(handler=cmd_replay)
    p = sub.add_parser("report", help="the tableau of a session")
    p.add_argument("file")
    p.add_argument("--iteration", type=int)
    p.add_argument("--format", choices=["text", "json", "csv"], default="text")
    p.set_defaults(handler=cmd_report)
    p = sub.add_parser("tradeoff", help="qcg penalty sweep (report 001, Figure 4)")
    p.add_argument("file")
    p.add_argument("--penalty", required=True, choices=["q1", "q2", "r1", "r2"])
    p.add_argument("--values", required=True, type=float, nargs="+", metavar="V")
    p.add_argument("--json", action="store_true")
    p.set_defaults(handler=cmd_tradeoff)
    p = sub.add_parser("examples", help="list (or copy) the bundled example sessions")
    p.add_argument("--copy", metavar="DIR")
    p.set_defaults(handler=cmd_examples)
    sweep_cli.add_parser(sub)
    return parser


def run_app(target: str | None = None, example: str | None = None) -> int:
    """The workbench: on a session file, on a bundled example, or the start screen."""
    from .app import LoopcraftApp
    from .files import example as example_copy
    path = None
    if example is not None:
        try:
            path = example_copy(example)
        except FileNotFoundError as exc:
            print(f"loopcraft: error: {exc}", file=sys.stderr)
            return 2
    elif target is not None:
        path = Path(target)
        if not path.is_file():
            print(f"loopcraft: error: {target}: no such file", file=sys.stderr)
            return 2
    result = LoopcraftApp(path).run()
    return result if isinstance(result, int) else 0


def _attached_values(argv: list[str]) -> list[str]:
    """``--tf -2/(s+1)`` as ``--tf=-2/(s+1)``: argparse takes a value that
    starts with '-' for an option otherwise."""
    out, k = [], 0
    while k < len(argv):
        if argv[k] in ("--tf", "--delay") and k + 1 < len(argv) and argv[k + 1].startswith("-"):
            out.append(f"{argv[k]}={argv[k + 1]}")
            k += 2
        else:
            out.append(argv[k])
            k += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0].endswith(".json"):
        return run_app(argv[0] if argv else None)
    if argv[0] == "--example":
        return run_app(example=argv[1] if len(argv) > 1 else "cip_launch_vehicle")
    parser = build_parser()
    args = parser.parse_args(_attached_values(argv))
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return args.handler(args)
    except (EngineError, CliError, SessionError) as exc:
        print(f"loopcraft {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

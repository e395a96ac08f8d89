"""The CLI's commands on a session file: run, replay, report, tradeoff,
examples, and the hand edits set and tune (`sessions.shaping`).  They use sessions and engine only (never the Textual app); the
algorithm-specific layout of a report comes from the algorithm's presenter."""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
from pathlib import Path

from engine.stepping.memory_fields import finite_or_none
from tui.cli.common import CliError, check_session_out, design_notes_now, load, rows_now, stop_notes_now, summary_json

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"

RUN_REMEDY = "save elsewhere with --out FILE, or make the file writable"


def cmd_run(args: argparse.Namespace) -> int:
    """Step the session's algorithm and save the records."""
    from engine.stepping.presenter import tableau_text
    from engine.stepping.protocol import StepRecord
    from sessions.lifecycle import adopt_current, switch_algorithm
    from sessions.runner import run_session, set_setting
    from sessions.store import OverwriteRefused, prepare_save, save_session

    session = load(args.file)
    check_session_out(session, args.out, args.force)
    try:
        prepare_save(session, args.out or args.file)  # before any work: the output is writable; autosaves go there
    except OverwriteRefused as exc:
        raise CliError(f"{exc} ({RUN_REMEDY})") from None
    if args.adopt:
        adopt_current(session)
    for assignment in args.set or ():
        set_setting(session, assignment)
    if args.algorithm:
        switch_algorithm(session, args.algorithm)
    show = sys.stderr.isatty() and not args.json

    def progress(record: StepRecord) -> None:
        if show:
            print(
                f"\riteration {record.iteration}: {record.status.value}"
                + ("" if record.objective is None else f", objective {record.objective:.6g}"),
                end="",
                file=sys.stderr,
                flush=True,
            )

    outcome = run_session(
        session, None if args.until_done else args.iterations, args.until_done, progress, time_limit=args.time_limit
    )
    if show:
        print(file=sys.stderr)
    try:
        save_session(session, args.out or args.file)
    except OverwriteRefused as exc:
        raise CliError(f"{exc}; the run is kept in its autosave ({RUN_REMEDY})") from None
    if outcome.stopped:
        print(f"note: stopped: {outcome.stopped}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary_json(session), indent=2, sort_keys=True))
    else:
        rows, record = rows_now(session)
        status = "not started" if record is None else record.status.value
        print(f"{session.model.algorithm.name}: iteration {session.model.current_iteration}, {status}")
        print(tableau_text(rows, session.problem.grid.unit))
        if record is not None and record.reason:
            print(f"stopped: {record.reason}" if record.status.finished else f"last step: {record.reason}")
        stops = stop_notes_now(session)
        print("".join(f"stop: {n}\n" for n in stops), end="")
        print("".join(f"note: {n}\n" for n in design_notes_now(session) if n not in stops), end="")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    """Re-run the session and compare every recorded iteration."""
    from sessions.runner import replay

    result = replay(load(args.file))
    print(result.message, file=sys.stdout if result.ok else sys.stderr)
    return 0 if result.ok else 1


def cmd_report(args: argparse.Namespace) -> int:
    """The tableau of an iteration as text (the algorithm's own layout), JSON or CSV;
    html and md: the design report (tui/cli/design_report.py)."""
    if args.format in ("html", "md"):
        from tui.cli.design_report import cmd_design_report

        return cmd_design_report(args)
    if args.out is not None:
        raise CliError("--out: only with --format html or md (text, json and csv are printed)")
    session = load(args.file)
    rows, record = rows_now(session, args.iteration)
    if args.format == "json":
        data = (
            summary_json(session)
            if args.iteration is None
            else {"iteration": args.iteration, "measures": [dict(vars(r), target=r.desired) for r in rows]}
        )
        print(json.dumps(data, indent=2, sort_keys=True, default=finite_or_none))
    elif args.format == "csv":
        writer = csv.writer(sys.stdout)
        writer.writerow(["name", "kind", "condition", "value", "frequency", "target", "satisfied", "method"])
        for r in rows:
            writer.writerow(
                [r.name, r.kind, r.condition, repr(r.value), r.frequency, r.desired, r.satisfied, r.method or ""]
            )
    else:
        from engine.stepping.presenter import tableau_text, tolerant
        from sessions.lifecycle import registration

        presenter = registration(session).presenter

        def generic() -> str:
            return tableau_text(rows, unit) + "\nnote: the record's algorithm data is malformed: the generic tableau"

        unit = session.problem.grid.unit
        print(
            tableau_text(rows, unit)
            if record is None
            else tolerant(lambda: presenter.report(record, session.problem), generic)
        )
        print("".join(f"note: {n}\n" for n in design_notes_now(session, args.iteration)), end="")
    return 0


def cmd_tradeoff(args: argparse.Namespace) -> int:
    """Report 001's penalty sweep: one optimized design per penalty value."""
    from engine.errors import EngineError
    from engine.qcg import Qcg
    from engine.qcg.tradeoff import penalty_sweep
    from engine.stepping.registry import make_settings
    from sessions.lifecycle import registration

    session = load(args.file)
    if registration(session).name != Qcg.name:
        raise CliError(
            f"tradeoff: {args.file} uses {session.model.algorithm.name!r}; the sweep needs a {Qcg.name} session"
        )
    settings = make_settings(session.model.algorithm.name, session.model.algorithm.settings)
    try:
        points = penalty_sweep(session.problem, settings, args.penalty, args.values)
    except EngineError as exc:
        raise CliError(str(exc)) from None
    if args.json:
        print(json.dumps([vars(p) for p in points], indent=2, sort_keys=True, default=finite_or_none))
        return 0
    names = list(points[0].parameters) if points else []
    print(
        f"{args.penalty:>10} {'x1^2 (N)':>10} {'x1dot^2 (N)':>12} {'u^2':>12} {'udot^2':>12} {'C':>12}  "
        + " ".join(f"{n:>10}" for n in names)
        + "  status"
    )
    for p in points:
        a = p.averaged_squares
        print(
            f"{p.penalty:>10.4g} {a['x1_normalized']:>10.4f} {a['x1_rate_normalized']:>12.4f} {a['u']:>12.5g} "
            f"{a['u_rate']:>12.5g} {p.cost:>12.6g}  "
            + " ".join(f"{p.parameters[n]:>10.5g}" for n in names)
            + f"  {p.status}"
        )
    return 0


def cmd_examples(args: argparse.Namespace) -> int:
    """List the bundled example sessions (and copy them with --copy DIR)."""
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


def cmd_set(args: argparse.Namespace) -> int:
    """Set or scale parameters of the design on screen; save; print what changed."""
    from sessions.shaping import Assignment, assign

    session = load(args.file)
    check_session_out(session, args.out, args.force)
    lines = assign(session, [Assignment.parse(text) for text in args.assignments])
    _save(session, args)
    print("\n".join(lines))
    print(_margins(session, 0))
    return 0


def cmd_tune(args: argparse.Namespace) -> int:
    """Solve the loop gain for a crossover frequency or a phase margin; save; print it."""
    from sessions.shaping import tune

    goal, _, number = args.gain_for.partition("=")
    if goal not in ("crossover", "pm") or not number:
        raise CliError(f"--gain-for {args.gain_for!r}: write crossover=W (rad/s) or pm=DEG")
    try:
        target = float(number)
    except ValueError:
        raise CliError(f"--gain-for {args.gain_for!r}: {number!r} is not a number") from None
    session = load(args.file)
    check_session_out(session, args.out, args.force)
    condition = _condition(session, args.condition)
    if args.pick is not None and goal != "pm":
        raise CliError("--pick: only with --gain-for pm=DEG (a crossover has one gain)")
    solution, line, choices, picked = tune(session, goal, target, args.parameter, condition, args.pick)
    _save(session, args)
    if args.json:
        print(json.dumps(_tune_json(solution, line, choices, picked), indent=2, sort_keys=True))
        return 0
    if len(choices) > 1:  # every solution, by frequency; the one taken marked
        print(f"{len(choices)} gains give pm={target:g} deg (--pick N takes another):")
        for k, choice in enumerate(choices):
            print(f"{'*' if k == picked else ' '} {k + 1}. {choice.text}")
    print(f"{line}  (x {solution.factor:.6g}, {solution.note})")
    print(f"crossover {solution.frequency:.6g} rad/s, phase margin {solution.phase_margin:.4f} deg there")
    print(_margins(session, condition))
    return 0


def _tune_json(solution, line: str, choices: list, picked: int | None) -> dict:
    """`tune --json`: what changed, the solution taken and, for a phase margin, every choice by frequency."""
    return {
        "changed": line,
        "factor": solution.factor,
        "frequency": solution.frequency,
        "phase_margin": solution.phase_margin,
        "note": solution.note,
        "picked": None if picked is None else picked + 1,
        "choices": [
            {
                "pick": k + 1,
                "frequency": c.solution.frequency,
                "factor": c.solution.factor,
                "parameter": c.parameter,
                "value": c.value,
                "breaks": list(c.breaks),
                "meets": list(c.meets),
            }
            for k, c in enumerate(choices)
        ],
    }


def _condition(session, name: str | None) -> int:
    names = [c.name for c in session.problem.conditions]
    if name is None:
        return 0
    if name not in names:
        raise CliError(f"--condition {name!r}: the session's conditions are {', '.join(names)}")
    return names.index(name)


def _save(session, args: argparse.Namespace) -> None:
    from sessions.store import OverwriteRefused, save_session

    try:
        save_session(session, args.out or args.file)
    except OverwriteRefused as exc:
        raise CliError(str(exc)) from None


def _margins(session, condition: int) -> str:
    """The analysis of a condition's loop at the session's start (now the edited design)."""
    from engine.analysis import analyze
    from tui.cli.analyze import analysis_to_text

    problem = session.problem
    c = problem.conditions[condition]
    result = analyze(c.network, c.break_at, problem.grid.omega, problem.condition_values(condition))
    return analysis_to_text(result, [f"{c.name}: the loop at {c.break_at}"])


def add_parsers(sub) -> None:
    """The session subcommands and their options."""
    p = sub.add_parser("run", help="run a session's algorithm and save its records")
    p.add_argument("file")
    p.add_argument("--algorithm", help="switch to this algorithm (restarts from iteration 0)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--iterations", type=int, default=1, metavar="N")
    group.add_argument("--until-done", action="store_true")
    p.add_argument(
        "--time-limit",
        type=float,
        metavar="SECONDS",
        help="stop stepping after this much wall-clock time (the records replay)",
    )
    p.add_argument("--out", help="save here instead of in place")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument("--json", action="store_true")
    p.add_argument(
        "--adopt", action="store_true", help="start from the current iteration's parameters (records are cleared)"
    )
    p.add_argument(
        "--set",
        action="append",
        metavar="NAME=VALUE",
        help="set an algorithm setting (restarts from iteration 0); repeatable",
    )
    p.set_defaults(handler=cmd_run)
    p = sub.add_parser("replay", help="re-run a session and compare every recorded iteration")
    p.add_argument("file")
    p.set_defaults(handler=cmd_replay)
    p = sub.add_parser("report", help="the tableau of a session")
    p.add_argument("file")
    p.add_argument("--iteration", type=int)
    p.add_argument("--format", choices=["text", "json", "csv", "html", "md"], default="text")
    p.add_argument(
        "--out", metavar="DIR", help="html, md: the folder to write the design report in (default: the working folder)"
    )
    p.add_argument("--force", action="store_true", help="html, md: replace the report's existing files")
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
    p = sub.add_parser(
        "set",
        help="set or scale parameters of a session's design (T1=2 T2*=0.5 K*=+3dB); the design becomes the start",
    )
    p.add_argument("file")
    p.add_argument("assignments", nargs="+", metavar="NAME=VALUE|NAME*=FACTOR|NAME*=+3dB")
    p.add_argument("--out", help="save here instead of in place")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.set_defaults(handler=cmd_set)
    p = sub.add_parser("tune", help="solve the loop gain for a crossover frequency or a phase margin, exactly")
    p.add_argument("file")
    p.add_argument("--gain-for", required=True, metavar="crossover=W|pm=DEG")
    p.add_argument(
        "--parameter", metavar="NAME", help="the gain parameter (default: the one the loop is proportional to)"
    )
    p.add_argument("--condition", metavar="NAME", help="the flight condition whose loop is solved (default: the first)")
    p.add_argument(
        "--pick",
        type=int,
        metavar="N",
        help="pm: the Nth solution by crossover frequency (default: the first that keeps every met "
        "requirement met, else the lowest)",
    )
    p.add_argument("--json", action="store_true", help="what changed and every solution, as JSON")
    p.add_argument("--out", help="save here instead of in place")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.set_defaults(handler=cmd_tune)

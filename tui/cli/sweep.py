"""`loopcraft sweep`: many runs of a session on Dask, clustered into local
optima (starts), a trade-off (vary) or a worst case (tolerance)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from sessions.sweeps.dispersion import PERCENTILE_KEYS, run_count
from sessions.sweeps.sampling import SAMPLINGS
from tui.cli.common import CliError, check_session_out

if TYPE_CHECKING:
    from sessions.sweeps.named_clusters import NamedCluster

INTERRUPTED = 130  # the exit status of a sweep stopped by Ctrl-C (128 + SIGINT), its finished runs kept


def add_parser(sub) -> None:
    """The `sweep` subcommand and its options (--allow-outside-tables: `tui.cli.build_parser`)."""
    p = sub.add_parser("sweep", help="many runs on Dask: multi-start, a parameter sweep, or a tolerance study")
    p.add_argument("file")
    what = p.add_mutually_exclusive_group()  # one of them is required, but for --print-job-script
    what.add_argument("--starts", type=int, metavar="N", help="N runs from random starting points")
    what.add_argument("--vary", metavar="NAME=V1,V2,...", help="one run per value of a penalty, parameter or path")
    what.add_argument(
        "--tolerance",
        action="append",
        metavar="NAME=+-P%|NAME=normal:P%",
        help="a tolerance study at the current design: NAME uniform within +-P %% or normal with sigma P %% "
        "(repeatable, one parameter each)",
    )
    p.add_argument("--spread", type=float, metavar="F", help="starts within a factor F of the session's start")
    p.add_argument("--samples", type=int, default=32, help="tolerance samples (default 32)")
    p.add_argument("--seed", type=int, default=0, help="the draws' seed: the same seed draws the same samples")
    p.add_argument(
        "--sampling", choices=SAMPLINGS, help="tolerance samples drawn at random (default) or by Latin hypercube (lhs)"
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="a running Dask scheduler")
    where.add_argument("--serial", action="store_true", help="in this process, one run after the other")
    where.add_argument(
        "--cluster",
        metavar="NAME",
        help="a cluster from Dask's configuration: local, or slurm, pbs, sge, lsf (dask-jobqueue's jobqueue.NAME)",
    )
    p.add_argument(
        "--min-jobs", type=int, metavar="N", help="a batch system's cluster keeps at least N jobs (default 0)"
    )
    p.add_argument("--max-jobs", type=int, metavar="N", help="... and scales up to N jobs (default 1)")
    p.add_argument("--print-job-script", action="store_true", help="print the job script --cluster would submit")
    p.add_argument(
        "--connect-timeout", type=float, metavar="SECONDS", help="how long to wait for the scheduler (default 5)"
    )
    p.add_argument("--workers", type=int, help="local cluster size (default: the machine's cores)")
    adopt = p.add_mutually_exclusive_group()
    adopt.add_argument(
        "--adopt-best",
        action="store_true",
        help="make the best optimum's best run the session's start (records are cleared)",
    )
    adopt.add_argument(
        "--adopt-worst",
        nargs="?",
        const="",
        metavar="MEASURE[@CONDITION]",
        help="a tolerance study: make the worst sample (of that measure, else of the row that misses its "
        "desired value by the most) the session's start, to look at (records are cleared)",
    )
    p.add_argument(
        "--save-samples",
        metavar="FILE.npz",
        help="a tolerance study's every sample as arrays: drawn parameter values and row values",
    )
    p.add_argument("--out", help="save here instead of in place")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument("--json", action="store_true", help="print one JSON object: runs and optima")
    p.set_defaults(handler=cmd_sweep)


def cmd_sweep(args: argparse.Namespace) -> int:
    """Plan, run and keep a sweep; print its summary.  Ctrl-C stops it and keeps the
    finished runs (exit status 130); a session that cannot be saved leaves the summary
    in NAME.sweep-recovery.json."""
    from sessions.store import load_session, prepare_save
    from sessions.sweeps.cluster import connect_timeout, scheduler_address, sigint_ignored
    from sessions.sweeps.named_clusters import job_script

    address = scheduler_address(args.scheduler)
    timeout = connect_timeout(args.connect_timeout)
    named = _named_cluster(args)
    if args.print_job_script:
        print(job_script(named))
        return 0
    if args.starts is None and args.vary is None and args.tolerance is None:
        raise CliError("one of --starts, --vary, --tolerance is required")
    if args.tolerance is None and (args.sampling is not None or args.adopt_worst is not None):
        raise CliError("--sampling and --adopt-worst are for a tolerance study (--tolerance)")
    if args.tolerance is None and args.save_samples:
        raise CliError("--save-samples is for a tolerance study (--tolerance)")
    target = Path(args.out or args.file)
    session = load_session(args.file)
    check_session_out(session, args.out, args.force)
    if args.adopt_worst:
        _check_row_named(session, args.adopt_worst)
    prepare_save(session, target)  # before any run: the output can be written
    try:
        kind, settings, outcome = _run(args, session, Where(address, named, timeout))
    except KeyboardInterrupt:
        print("loopcraft sweep: interrupted before any run finished; nothing saved", file=sys.stderr)
        return INTERRUPTED
    with sigint_ignored():
        return _keep(args, session, kind, settings, outcome, target)


def _check_row_named(session, which: str) -> None:
    """--adopt-worst MEASURE[@CONDITION] names a row of the session's tableau (the study's
    rows), checked before any sample runs."""
    from sessions.errors import SessionError
    from sessions.sweeps.dispersion import rows_named
    from tui.cli.common import rows_now

    rows, _ = rows_now(session, 0)
    try:
        rows_named([{"name": r.name, "condition": r.condition} for r in rows], which)
    except SessionError as exc:
        raise CliError(f"--adopt-worst: {exc}; nothing ran") from None


def _named_cluster(args: argparse.Namespace) -> NamedCluster | None:
    """--cluster NAME checked (None without it); --min-jobs, --max-jobs and --print-job-script need it."""
    from sessions.sweeps.named_clusters import named_cluster

    if args.cluster is None:
        if args.min_jobs is not None or args.max_jobs is not None or args.print_job_script:
            raise CliError("--min-jobs, --max-jobs and --print-job-script are for --cluster NAME")
        return None
    return named_cluster(args.cluster, args.min_jobs, args.max_jobs)


class Where(NamedTuple):
    """Where the runs go: a scheduler's address, a named cluster or neither (a local
    cluster), reached within ``timeout`` seconds."""

    address: str | None
    cluster: NamedCluster | None
    timeout: float


def _run(args: argparse.Namespace, session, where: Where):
    """Plan the sweep and run its jobs: (kind, settings, outcome)."""
    from sessions.sweeps.jobs import execute, execute_serial
    from sessions.sweeps.plan import plan

    kind, value = (
        ("starts", args.starts)
        if args.starts is not None
        else ("vary", args.vary)
        if args.vary is not None
        else ("tolerance", args.tolerance)
    )
    jobs, settings = plan(session, kind, value, args.spread, args.seed, args.samples, args.sampling or "random")
    settings["scheduler"] = where.address or (
        "serial" if args.serial else where.cluster.name if where.cluster else "local"
    )
    progress = _progress_bar if sys.stderr.isatty() and not args.json else None
    outcome = (
        execute_serial(jobs, progress)
        if args.serial
        else execute(jobs, where.address, args.workers, progress, timeout=where.timeout, cluster=where.cluster)
    )
    if progress:
        print(file=sys.stderr)
    if outcome.note:
        print(f"loopcraft sweep: {outcome.note}", file=sys.stderr)
    return kind, settings, outcome


def _keep(args: argparse.Namespace, session, kind: str, settings: dict, outcome, target: Path) -> int:
    """Keep the sweep in the session (or in a recovery file), print it; the exit status."""
    from sessions.sweeps.results import record_sweep, summarize

    summary = summarize(session, kind, settings, outcome)
    if args.save_samples:
        from sessions.sweeps.results import save_samples

        saved = save_samples(Path(args.save_samples), session, settings, outcome)
        print(f"loopcraft sweep: every sample's values in {saved}", file=sys.stderr)
    record_sweep(session, summary)
    adopt_error = _adopt(args, session, summary) if not outcome.interrupted else None
    kept, in_session = _save(session, summary, target)
    print(json.dumps(with_former_keys(summary), indent=2, sort_keys=True) if args.json else sweep_text(summary))
    if outcome.interrupted:
        print(
            f"loopcraft sweep: interrupted: {outcome.finished} of {run_count(summary)} finished; "
            f"kept {'in ' + str(kept) if kept else 'above'} as a cancelled sweep"
            + (f" ({_adopt_option(args)} not applied)" if _adopt_option(args) else ""),
            file=sys.stderr,
        )
        return INTERRUPTED
    if adopt_error:
        print(f"loopcraft sweep: error: {adopt_error} (the sweep is kept)", file=sys.stderr)
    return 0 if in_session and not adopt_error else 2


def _adopt_option(args: argparse.Namespace) -> str | None:
    """The adopt option given, if any."""
    return "--adopt-best" if args.adopt_best else "--adopt-worst" if args.adopt_worst is not None else None


def _adopt(args: argparse.Namespace, session, summary: dict) -> str | None:
    """--adopt-best or --adopt-worst, when given: why not, if it cannot."""
    if args.adopt_best:
        return _adopt_best(session, summary)
    if args.adopt_worst is not None:
        return _adopt_worst(session, summary, args.adopt_worst or None)
    return None


def _adopt_worst(session, summary: dict, which: str | None) -> str | None:
    """--adopt-worst: a tolerance study's worst sample becomes the start (said on
    standard error, with its values); why not, if it cannot."""
    from sessions.errors import SessionError
    from sessions.sweeps.results import adopt_worst

    try:
        row, run, widened = adopt_worst(session, summary, which)
    except SessionError as exc:
        return f"--adopt-worst: {exc}"
    print(
        f"note: the start is now sample {run['index']}, the worst of {row['name']} at {row['condition']} "
        f"({_number(row['worst'], 0).strip()} against {_number(row['desired'], 0).strip()}): {_values(run['start'])}",
        file=sys.stderr,
    )
    for note in widened:
        print(f"note: {note}", file=sys.stderr)
    return None


def _adopt_best(session, summary: dict) -> str | None:
    """--adopt-best: the best optimum's best run becomes the start; why not, if it cannot."""
    from sessions.errors import SessionError
    from sessions.sweeps.results import adopt_run

    if not summary["optima"]:
        return "--adopt-best: no run finished"
    try:
        widened = adopt_run(session, summary["runs"][summary["optima"][0]["best_run"]])
    except SessionError as exc:
        return f"--adopt-best: {exc}"
    for note in widened:
        print(f"note: {note}", file=sys.stderr)
    return None


def _save(session, summary: dict, target: Path) -> tuple[Path | None, bool]:
    """Save the session; failing that, the summary in a recovery file (said on stderr).
    Where the sweep is kept (None: only in the output printed), and whether in the session."""
    from sessions.errors import SessionError
    from sessions.store import save_session
    from sessions.sweeps.results import write_recovery

    try:
        return save_session(session, target), True
    except (SessionError, OSError, ValueError) as exc:
        failure = f"loopcraft sweep: error: the session cannot be saved: {exc}"
    try:
        recovery = write_recovery(summary, target)
    except SessionError as exc:
        print(f"{failure}; {exc}: the sweep is only in the output", file=sys.stderr)
        return None, False
    print(f"{failure}; the sweep's results are in {recovery}", file=sys.stderr)
    return recovery, False


def _progress_bar(done: int, total: int) -> None:
    width = 30
    filled = round(width * done / total)
    print(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} runs", end="", file=sys.stderr, flush=True)


def _number(value, width: int = 12) -> str:
    if isinstance(value, (int, float)) and math.isfinite(value):
        return f"{value:>{width}.6g}"
    return f"{'-' if value is None else str(value):>{width}}"


def _values(parameters: dict) -> str:
    return "  ".join(
        f"{k}=" + ("/".join(f"{v:.4g}" for v in value) if isinstance(value, list) else f"{value:.4g}")
        for k, value in parameters.items()
    )


def sweep_text(summary: dict) -> str:
    """Runs, then optima (or the worst case of a tolerance study)."""
    runs = summary["runs"]
    lines = [
        f"{summary['kind']} sweep: {run_count(summary)} on {summary['workers']} worker(s), "
        + (excluded_text(summary) or f"{len(summary['failed'])} failed")
        + f", {len(summary['retried'])} retried"
    ]
    lines.append(f"{'run':>4} {'label':<18}{'status':<24}{'ranking':>12} {'meets':<6}{'tries':>5}")
    for r in runs:
        lines.append(
            f"{r['index']:>4} {r['label'][:17]:<18}{r['status'][:23]:<24}{_number(r['ranking'])} "
            f"{'yes' if r['meets_requirements'] else 'no':<6}{r.get('attempts', 1):>5}"
            + (f"  {r['reason']}" if r["status"] == "failed" else "")
        )
    if summary["kind"] == "vary" and any("averaged_squares" in r for r in runs):
        lines += ["", "trade-off (averaged squares, normalized to open loop where named so):"]
        for r in runs:
            squares = r.get("averaged_squares") or {}
            lines.append(f"  {r['label']:<18}" + "  ".join(f"{k}={v:.5g}" for k, v in squares.items()))
    if summary["kind"] == "tolerance":
        lines += ["", f"{'measure':<10}{'kind':<22}{'condition':<12}{'worst':>12}{'target':>10}  unmet/samples"]
        for w in summary["worst_case"]:
            lines.append(
                f"{w['name']:<10}{w['kind'][:21]:<22}{w['condition'][:11]:<12}{_number(w['worst'])}"
                f"{_number(w['desired'], 10)}  {w['unmet_samples']}/{w['samples']}"
            )
        lines += _distribution_lines(summary["worst_case"])
    else:
        lines += ["", f"{'optimum':>7} {'count':>5} {'meets':<6}{'ranking':>12} {'best run':>8}  parameters"]
        for k, o in enumerate(summary["optima"], start=1):
            lines.append(
                f"{k:>7} {o['count']:>5} {'yes' if o['meets_requirements'] else 'no':<6}"
                f"{_number(o['ranking'])} {o['best_run']:>8}  {_values(o['parameters'])}"
            )
            lines += [f"{'':>13}note: {n}" for n in o.get("notes", [])]
    return "\n".join(lines)


def excluded_text(summary: dict) -> str:
    """A tolerance study's samples left out of its statistics, by reason: "statistics over
    203 of 400 samples, 197 excluded (197: the loop is singular)" ("" when none is)."""
    from sessions.errors import cut

    excluded = summary.get("excluded") or {}
    if not excluded:
        return ""
    total = sum(excluded.values())
    samples = summary.get("settings", {}).get("samples", len(summary["runs"]))
    reasons = "; ".join(f"{n}: {cut(reason, 120)}" for reason, n in excluded.items())
    return f"statistics over {samples - total} of {samples} samples, {total} excluded ({reasons})"


def _distribution_lines(rows: list[dict]) -> list[str]:
    """Each row's percentiles, fraction unmet with its 95 % interval, and worst sample with
    its drawn values (rows of sweeps saved before version 2's distributions have none)."""
    rows = [w for w in rows if w.get("percentiles") is not None]
    if not rows:
        return []
    lines = ["", f"{'measure':<10}{'condition':<12}" + "".join(f"{p:>11}" for p in PERCENTILE_KEYS)]
    lines[-1] += "  unmet % [95 % interval]  worst sample: values"
    for w in rows:
        low, high = w["unmet_interval"]
        lines.append(
            f"{w['name']:<10}{w['condition'][:11]:<12}"
            + "".join(_number(w["percentiles"].get(p), 11) for p in PERCENTILE_KEYS)
            + f"  {100 * w['unmet_fraction']:5.1f} [{100 * low:.1f}, {100 * high:.1f}]"
            + f"  {w['worst_sample']}: {_values(w['worst_parameters'])}"
        )
    return lines


def with_former_keys(summary: dict) -> dict:
    """The summary as `sweep --json` printed it before the names were made one per idea:
    each run's and optimum's ranking value also as "objective", each measure's and worst
    case's desired value also as "target" (other programs read those keys)."""

    def measure(row: dict) -> dict:
        return {**row, "target": row.get("desired")}

    runs = [
        {**r, "objective": r.get("ranking"), "measures": [measure(m) for m in r.get("measures", [])]}
        for r in summary.get("runs", [])
    ]
    optima = [{**o, "objective": o.get("ranking")} for o in summary.get("optima", [])]
    worst = [measure(w) for w in summary.get("worst_case", [])]
    return {**summary, "runs": runs, "optima": optima, "worst_case": worst}

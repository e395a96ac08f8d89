"""`loopcraft export`: a design as a python-control script, a MATLAB script,
JSON data or a CSV frequency response (sessions.export_*)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from sessions.export.formats import SUFFIX
from tui.cli.common import CliError, load


def target_path(file: str, out: str | None, to: str, iteration: int | None) -> Path | None:
    """Where to write: None for standard output; a folder gets NAME[_iterK].SUFFIX inside it."""
    if out is None or out == "-":
        return None
    path = Path(out)
    if path.is_dir():
        stem = Path(file).stem.replace("-", "_").replace(".", "_")
        path = path / f"{stem}{'' if iteration is None else f'_iter{iteration}'}{SUFFIX[to]}"
    if not path.parent.is_dir():
        raise CliError(f"--out {out}: the folder {path.parent} does not exist")
    return path


def cmd_export(args: argparse.Namespace) -> int:
    """Write the design of one iteration in the chosen format (never over an input of the
    command, a file that is not a regular one, or an existing file without --force)."""
    from sessions.export.formats import export_text
    from sessions.format.save_file import check_output, write_atomic
    from sessions.store import files_read

    if args.sample_time is not None and not (math.isfinite(args.sample_time) and args.sample_time > 0):
        raise CliError(f"--sample-time: {args.sample_time!r} must be a finite number > 0")
    target = target_path(args.file, args.out, args.to, args.iteration)
    session = load(args.file)
    if target is not None:
        check_output(target, files_read(session), args.force)
    try:
        text = export_text(session, args.iteration, args.to, args.sample_time, args.fit)
    except ValueError as exc:  # e.g. JSON refusing a non-finite number
        raise CliError(f"--to {args.to}: {exc}") from None
    if target is None:
        sys.stdout.write(text)
        return 0
    try:
        write_atomic(target, text)
    except OSError as exc:
        raise CliError(f"--out {target}: cannot write: {exc.strerror or exc}") from None
    print(f"wrote {target}", file=sys.stderr)
    return 0


def add_parser(sub) -> None:
    """The export subcommand and its options."""
    p = sub.add_parser("export", help="export a design: python-control or MATLAB script, JSON, CSV response")
    p.add_argument("file")
    p.add_argument("--iteration", type=int, metavar="K", help="the iteration (default: the last; 0: the start)")
    p.add_argument("--to", required=True, choices=list(SUFFIX))
    p.add_argument(
        "--out",
        metavar="PATH",
        help="a file, or a folder (NAME.py, .m, .export.json, .csv inside); default: standard output",
    )
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument(
        "--sample-time",
        type=float,
        metavar="T",
        help="w-plane designs: the sample time of the z-domain forms (default: unstated)",
    )
    p.add_argument(
        "--fit",
        action="store_true",
        help="tables as their rational (AAA) fits, residual stated, refused with right-half-plane artefacts "
        "(default: the tables themselves, as frd)",
    )
    p.set_defaults(handler=cmd_export)

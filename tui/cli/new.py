"""`loopcraft new`: a new session from a plant (an expression, or a .mat/.npz
file) and a compensator structure (sessions.new.templates, sessions.new.importers)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tui.cli.common import CliError


def cmd_new(args: argparse.Namespace) -> int:
    """Create FILE.json (refusing to overwrite one unless --force)."""
    from sessions.format.save_file import check_output
    from sessions.new.templates import new_session
    from sessions.store import parse_session, save_session

    target = Path(args.file)
    if target.suffix != ".json":
        raise CliError(f"{args.file}: a session file ends in .json")
    if not target.parent.is_dir():
        raise CliError(f"{args.file}: the folder {target.parent} does not exist")
    inputs = {} if args.plant_file is None else {Path(args.plant_file): "the plant file"}
    check_output(target, inputs, args.force, option="")
    if (args.plant is None) == (args.plant_file is None):
        raise CliError("give --plant EXPR or --plant-file F.mat|F.npz (one of them)")
    grid, table = None, None
    if args.plant_file is not None:
        from sessions.new.importers import read_plant_file

        imported = read_plant_file(args.plant_file, target)
        plant, grid, table = imported.plant, imported.grid, imported
        notes = f"A new session: the plant is the {imported.description}."
    else:
        plant, notes = args.plant, ""
    if args.sample_time is not None and args.plant_file is not None:
        raise CliError("--sample-time: give the plant as --plant EXPR (in s, discretized; or in z)")
    data = new_session(
        plant,
        args.compensator,
        args.algorithm,
        grid=grid,
        notes=notes,
        sample_time=args.sample_time,
        discretize=args.discretize,
    )
    if table is not None and table.csv_name:
        check_output(target.parent / table.csv_name, inputs, args.force, option="")
        _write(target.parent / table.csv_name, table.csv_text)
    session = parse_session(json.dumps(data), str(target), target.parent)  # what is written loads
    save_session(session, target, force=True)
    print(
        f"wrote {target}" + (f" and {target.parent / table.csv_name}" if table and table.csv_name else ""),
        file=sys.stderr,
    )
    return 0


def _write(path: Path, text: str) -> None:
    try:
        from sessions.format.save_file import write_atomic

        write_atomic(path, text)
    except OSError as exc:
        raise CliError(f"{path}: cannot write the plant's table: {exc.strerror or exc}") from None


def add_parser(sub) -> None:
    """The new subcommand and its options."""
    from sessions.new.templates import STRUCTURES

    p = sub.add_parser("new", help="a new session: unity feedback, a compensator structure, PM/GM targets")
    p.add_argument("file", metavar="FILE.json")
    p.add_argument("--plant", metavar="EXPR", help="the plant, an expression in s (or w): numbers only")
    p.add_argument(
        "--plant-file",
        metavar="F.mat|F.npz",
        help="the plant from arrays num/den, A/B/C/D, or freq/resp (a table written beside FILE)",
    )
    p.add_argument(
        "--compensator",
        default="lead",
        metavar="|".join(STRUCTURES) + "|EXPR",
        help="a structure, or an expression whose names are the parameters (default lead)",
    )
    p.add_argument(
        "--algorithm",
        metavar="NAME",
        help="the algorithm, one that offers new sessions (default: the first of them)",
    )
    p.add_argument(
        "--sample-time",
        type=float,
        metavar="T",
        help="a loop in z sampled every T s: a plant in s is discretized (--discretize), one in z kept; "
        "the compensator's structure by Tustin's map",
    )
    p.add_argument(
        "--discretize",
        choices=("zoh", "tustin", "matched"),
        default="zoh",
        help="how a plant in s is discretized with --sample-time (default zoh: exact, its exp(-T*s) delay "
        "as whole and fractional samples)",
    )
    p.add_argument("--force", action="store_true", help="replace an existing FILE")
    p.set_defaults(handler=cmd_new)

"""`loopcraft compare`: two designs' measures side by side (sessions.compare)."""

from __future__ import annotations

import argparse
import json

from tui.cli.common import CliError, load


def cmd_compare(args: argparse.Namespace) -> int:
    """A.json B.json (each at its last iteration), or A.json --iterations I J."""
    from sessions.compare import compare, comparison_json, comparison_text, problem_differences, side

    if (args.b is None) == (args.iterations is None):
        raise CliError("give a second session (compare A.json B.json) or --iterations I J (of A.json)")
    a = load(args.a)
    if args.iterations is not None:
        i, j = args.iterations
        left, right, differences = side(a, i, f"{args.a}"), side(a, j, f"{args.a}"), ()
    else:
        b = load(args.b)
        left, right, differences = side(a, None, args.a), side(b, None, args.b), problem_differences(a, b)
    result = compare(left, right, differences)
    if args.json:
        print(json.dumps(comparison_json(result), indent=2, sort_keys=True))
    else:
        print(comparison_text(result))
    return 0


def add_parser(sub) -> None:
    """The compare subcommand and its options."""
    p = sub.add_parser("compare", help="two designs' measures side by side, which meets more targets")
    p.add_argument("a", metavar="A.json")
    p.add_argument("b", metavar="B.json", nargs="?")
    p.add_argument("--iterations", type=int, nargs=2, metavar=("I", "J"), help="compare two iterations of A")
    p.add_argument("--json", action="store_true")
    p.set_defaults(handler=cmd_compare)

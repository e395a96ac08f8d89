"""The `loopcraft` command line: headless analysis, runs, reports and sweeps,
and the app when no command is given.

Nothing here imports Textual or an algorithm at module level: `--help` and
`analyze` start as fast as numpy and pydantic allow, and a command imports
only what it uses (a cip session loads the cip package alone)."""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

from engine.errors import EngineError
from sessions.errors import SessionError, bounded_message
from sessions.format.save_file import describe
from tui.cli import analyze, compare, config_command, export, new, session_commands, sweep
from tui.cli.common import CliError
from tui.cli.options import check_options


class Parser(argparse.ArgumentParser):
    """argparse's parser whose errors are one line (what is wrong, and where the usage is;
    argparse prints the usage over several lines first) echoing no more than
    `bounded_message` lets through of a bad value (its subcommands' parsers are of this
    class too)."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {bounded_message(message)} ({self.prog} --help: the usage)\n")


def build_parser() -> argparse.ArgumentParser:
    """Every subcommand and its options."""
    parser = Parser(
        prog="loopcraft",
        usage="loopcraft [FILE.json | --example NAME] | loopcraft COMMAND ...",
        description="Classical compensator design workbench. Without a command: the app, on FILE.json, on a "
        "bundled example (--example NAME), or on its start screen.",
    )
    parser.add_argument(
        "--example",
        metavar="NAME",
        help="open the app on a bundled example (a working copy): " + ", ".join(_example_names()),
    )
    sub = parser.add_subparsers(dest="command", prog="loopcraft")
    analyze.add_parser(sub)
    session_commands.add_parsers(sub)
    sweep.add_parser(sub)
    export.add_parser(sub)
    new.add_parser(sub)
    compare.add_parser(sub)
    config_command.add_parser(sub)
    for name in TABLE_COMMANDS:
        sub.choices[name].add_argument(
            "--allow-outside-tables",
            action="store_true",
            help="read CSV tables outside the session's folder (absolute paths, .., symlinks leading out)",
        )
    return parser


TABLE_COMMANDS = (
    "run",
    "replay",
    "report",
    "tradeoff",
    "sweep",
    "analyze",
    "export",
    "compare",
)  # those that read tables


def _handle(args: argparse.Namespace) -> int:
    """The command's handler; with --allow-outside-tables, inside `outside_tables_allowed`."""
    if not getattr(args, "allow_outside_tables", False):
        return args.handler(args)
    from sessions.build import outside_tables_allowed

    with outside_tables_allowed():
        return args.handler(args)


def run_app(target: str | None = None, example: str | None = None) -> int:
    """The workbench: on a session file, on a bundled example, or the start screen."""
    from tui.app import LoopcraftApp
    from tui.files import example as example_copy

    path = None
    if example is not None:
        try:
            path = example_copy(example)
        except FileNotFoundError as exc:
            print(f"loopcraft: error: {exc}", file=sys.stderr)
            return 2
    elif target is not None:
        from tui.files import file_problem

        path = Path(target)
        problem = file_problem(path)
        if problem is not None:
            print(f"loopcraft: error: {bounded_message(f'{target}: {problem}')}", file=sys.stderr)
            return 2
    streams = [
        name for name, stream in (("input", sys.stdin), ("output", sys.stdout)) if stream is None or not stream.isatty()
    ]
    if streams:  # the app would draw for no one (and keep a core busy doing it)
        verb = "is not one" if len(streams) == 1 else "are not terminals"
        print(
            f"loopcraft: error: the workbench needs a terminal: standard {' and '.join(streams)} {verb} "
            "(for scripts: loopcraft run, analyze, report, export; see loopcraft --help)",
            file=sys.stderr,
        )
        return 2
    from tui.stderr_log import stderr_to_log
    from tui.terminal_watch import HANGUP_EXIT, terminal_attached

    app = LoopcraftApp(path, graphics=_graphics())
    try:
        with stderr_to_log():  # Dask's and the workers' logs never over the screen (the help names the file)
            result = app.run()
    except Exception:
        if terminal_attached():
            raise
        result = None  # a write to the hung-up terminal failed before the terminal watch noticed it
    if not terminal_attached():  # whatever ended the app once its terminal went away: its work is autosaved
        if app.bench is not None:
            app.bench.file.autosave()
        return HANGUP_EXIT
    return result if isinstance(result, int) else 0


def _graphics():
    """The terminal's image protocol when the config asks for image plots (asked now: not
    once the app has the terminal); None: text plots (a config that does not read is
    reported by the app)."""
    from tui.config import ConfigError, load_config

    try:
        if load_config().plots != "image":
            return None
    except ConfigError:
        return None
    from tui.drawing.graphics import probe

    try:
        return probe()
    except Exception:  # noqa: BLE001 - a terminal that answers oddly gets text plots, never a crash
        return None


def _example_names() -> list[str]:
    from tui.files import EXAMPLES

    return sorted(p.stem for p in EXAMPLES.glob("*.json"))


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


def survive_any_text() -> None:
    """Standard output and error write any string a JSON file can hold: a lone
    surrogate ("\\ud800" in a name) is written as its escape, never an error."""
    for stream in {sys.stdout, sys.stderr, sys.__stdout__, sys.__stderr__}:
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            reconfigure(errors="backslashreplace")


def main(argv: Sequence[str] | None = None) -> int:
    """The console script: a command, or the app (on a FILE.json or --example NAME).

    As the console script (``argv`` None) no RuntimeWarning reaches the terminal (numpy's
    overflow in an intermediate is not the user's to read; results are checked where they
    are made); called in-process (tests, the fuzzer) warnings go where the caller's filters
    send them, so that they can be counted."""
    if argv is None:
        warnings.filterwarnings("ignore", category=RuntimeWarning)
    survive_any_text()
    argv = list(sys.argv[1:] if argv is None else argv)
    wants_help = any(a in ("-h", "--help") for a in argv)
    if not wants_help and (not argv or argv[0].endswith(".json")):
        if len(argv) > 1:
            print(f"loopcraft: error: unexpected {' '.join(argv[1:])!r} after the session file", file=sys.stderr)
            return 2
        return run_app(argv[0] if argv else None)
    if not wants_help and argv[0] == "--example":
        if len(argv) != 2:
            print("loopcraft: error: --example takes one NAME: " + ", ".join(_example_names()), file=sys.stderr)
            return 2
        return run_app(example=argv[1])
    if argv and (argv[0].endswith(".json") or argv[0] == "--example"):
        argv = ["--help"]
    parser = build_parser()
    args = parser.parse_args(_attached_values(argv))
    if args.command is None:
        parser.print_help()
        return 0
    try:
        check_options(args)
        return _handle(args)
    except (EngineError, CliError, SessionError) as exc:
        print(f"loopcraft {args.command}: error: {bounded_message(str(exc))}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the output's reader stopped early (| head): not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a path the user typed (a name over 255 bytes, a folder for a file, ...)
        where = f"{exc.filename}: " if exc.filename is not None else ""
        print(f"loopcraft {args.command}: error: {bounded_message(where + describe(exc))}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

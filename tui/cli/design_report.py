"""`loopcraft report FILE --format html|md --out DIR`: the design report
(sessions.report.content, report_render); the text, JSON and CSV formats
stay in session_commands."""

from __future__ import annotations

import argparse
from pathlib import Path

from tui.cli.common import CliError, load

FORMATS = ("html", "md")


def cmd_design_report(args: argparse.Namespace) -> int:
    """Write DIR/NAME.html (self-contained) or DIR/NAME.md with its PNGs (DIR: --out, else
    the working folder, never the session's own unasked), and say where.  No file written
    replaces an input of the command, a file that is not a regular one, or (without
    --force) an existing file."""
    from sessions.format.save_file import check_output
    from sessions.report.content import report_blocks
    from sessions.report.render import write_report
    from sessions.store import files_read

    folder = Path(args.out) if args.out else Path.cwd()
    if folder.exists() and not folder.is_dir():
        raise CliError(f"--out {args.out}: not a folder")
    session = load(args.file)
    try:
        blocks = report_blocks(session, args.iteration)
    except ImportError as exc:
        raise CliError(f"--format {args.format}: the figures need matplotlib ({exc})") from None
    inputs = files_read(session)
    written = write_report(
        blocks, args.format, folder, Path(args.file).stem, lambda path: check_output(path, inputs, args.force)
    )
    print(
        f"wrote {written[0].resolve()}" + (f" and {len(written) - 1} figure(s) beside it" if len(written) > 1 else "")
    )
    return 0

"""The design report written out: one self-contained HTML file from a Jinja2 template
(figures embedded as base64 PNG data URIs, no external resource; a print stylesheet
so that a browser's "print to PDF" gives a clean document) or Markdown with the
PNGs written beside it (`sessions.report.content` gives the blocks)."""

from __future__ import annotations

import base64
from collections.abc import Callable
from pathlib import Path

from sessions.errors import SessionError
from sessions.format.save_file import write_atomic
from sessions.report.content import Block

TEMPLATES = Path(__file__).resolve().parent / "templates"


def render_html(blocks: list[Block]) -> str:
    """One HTML document from the template (``templates/report.html``: every value
    escaped, every figure a data: URI, a print stylesheet for a browser's PDF)."""
    from jinja2 import Environment, FileSystemLoader, select_autoescape

    environment = Environment(loader=FileSystemLoader(TEMPLATES), autoescape=select_autoescape(["html"]))
    title = next((b[1] for b in blocks if b[0] == "h1"), "Design report")
    return environment.get_template("report.html").render(title=title, blocks=[_fields(b) for b in blocks])


def _fields(block: Block) -> dict:
    """A block as the template reads it."""
    kind = block[0]
    if kind == "table":
        return {"kind": kind, "header": [str(h) for h in block[1]], "rows": [[str(c) for c in r] for r in block[2]]}
    if kind == "figure":
        data = base64.b64encode(block[2]).decode("ascii")
        return {"kind": kind, "name": block[1], "data": data, "caption": block[3]}
    return {"kind": kind, "text": block[1]}


def render_markdown(blocks: list[Block], stem: str) -> tuple[str, dict[str, bytes]]:
    """Markdown text and the PNG files it links (name -> bytes, written beside it)."""
    out, files = [], {}
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3"):
            out.append("#" * int(kind[1]) + " " + block[1])
        elif kind == "p":
            out.append(block[1])
        elif kind == "note":
            out.append("> **Note.** " + block[1].replace("\n", "\n> "))
        elif kind == "pre":
            out.append("```\n" + block[1] + "\n```")
        elif kind == "table":
            out.append(_md_table(block[1], block[2]))
        elif kind == "figure":
            name = f"{stem}_{block[1]}.png"
            files[name] = block[2]
            out.append(f"![{block[3]}]({name})")
    return "\n\n".join(out) + "\n", files


def _md_table(header, rows) -> str:
    def cell(x) -> str:
        return str(x).replace("|", "\\|").replace("\n", " ")

    lines = ["| " + " | ".join(cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def write_report(
    blocks: list[Block], fmt: str, folder: Path, stem: str, check: Callable[[Path], None] = lambda _: None
) -> list[Path]:
    """Write the report as ``folder/stem.html`` or ``folder/stem.md`` (+ its PNGs); the files
    written.  ``check`` sees every file before any is written (it raises to refuse one)."""
    folder = Path(folder)
    try:
        if fmt == "html":
            files, target = {}, folder / f"{stem}.html"
            text = render_html(blocks)
        else:
            (text, files), target = render_markdown(blocks, stem), folder / f"{stem}.md"
        for path in [target, *(folder / name for name in files)]:
            check(path)
        folder.mkdir(parents=True, exist_ok=True)
        written = []
        for name, data in files.items():
            write_atomic(folder / name, data)
            written.append(folder / name)
        write_atomic(target, text)
        return [target] + written
    except OSError as exc:
        raise SessionError(f"--out {folder}: cannot write the report: {exc.strerror or exc}") from None

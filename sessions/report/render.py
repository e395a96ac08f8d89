"""The design report written out: one self-contained HTML file (figures embedded
as base64 PNG data URIs, no external resource) or Markdown with the PNGs
written beside it (`sessions.report.content` gives the blocks)."""

from __future__ import annotations

import base64
import html
from pathlib import Path

from sessions.errors import SessionError
from sessions.format.save_file import write_atomic
from sessions.report.content import Block

STYLE = (
    "body{font-family:sans-serif;max-width:60em;margin:2em auto;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:2px 6px;"
    "font-size:90%}th{background:#eee}pre{background:#f6f6f6;padding:0.5em;overflow-x:auto}"
    "td.unmet{color:#b00;font-weight:bold}figure{margin:1em 0}img{max-width:100%}"
)


def render_html(blocks: list[Block]) -> str:
    """One HTML document; every figure a data: URI."""
    title = next((b[1] for b in blocks if b[0] == "h1"), "Design report")
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>",
    ]
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3", "p"):
            out.append(f"<{kind}>{html.escape(block[1])}</{kind}>")
        elif kind == "pre":
            out.append(f"<pre>{html.escape(block[1])}</pre>")
        elif kind == "table":
            out.append(_html_table(block[1], block[2]))
        elif kind == "figure":
            data = base64.b64encode(block[2]).decode("ascii")
            out.append(
                f'<figure><img alt="{html.escape(block[1])}" src="data:image/png;base64,{data}">'
                f"<figcaption>{html.escape(block[3])}</figcaption></figure>"
            )
    out.append("</body></html>")
    return "\n".join(out) + "\n"


def _html_table(header, rows) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join(
        "<tr>"
        + "".join(f"<td{' class=unmet' if cell == 'UNMET' else ''}>{html.escape(str(cell))}</td>" for cell in row)
        + "</tr>"
        for row in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def render_markdown(blocks: list[Block], stem: str) -> tuple[str, dict[str, bytes]]:
    """Markdown text and the PNG files it links (name -> bytes, written beside it)."""
    out, files = [], {}
    for block in blocks:
        kind = block[0]
        if kind in ("h1", "h2", "h3"):
            out.append("#" * int(kind[1]) + " " + block[1])
        elif kind == "p":
            out.append(block[1])
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


def write_report(blocks: list[Block], fmt: str, folder: Path, stem: str) -> list[Path]:
    """Write the report as ``folder/stem.html`` or ``folder/stem.md`` (+ its PNGs); the files written."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if fmt == "html":
            target = folder / f"{stem}.html"
            write_atomic(target, render_html(blocks))
            return [target]
        text, files = render_markdown(blocks, stem)
        written = []
        for name, data in files.items():
            (folder / name).write_bytes(data)
            written.append(folder / name)
        target = folder / f"{stem}.md"
        write_atomic(target, text)
        return [target] + written
    except OSError as exc:
        raise SessionError(f"--out {folder}: cannot write the report: {exc.strerror or exc}") from None

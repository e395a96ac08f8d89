"""The HTML report printed by Debian's Chromium splits no table across pages where it fits on one, and
keeps the line that introduces a table ("Closed loop: ...; its poles:") with it: each table's first
and last cells and each introducing paragraph carry a marker word in a copy of the report, and
poppler's `pdftotext -bbox` says on which page and where each landed.  Skipped where Chromium or
pdftotext is missing, except under CI=true (`.ci/run` installs both)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from tui.cli import main

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
PDFTOTEXT = shutil.which("pdftotext")
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        (CHROMIUM is None or PDFTOTEXT is None) and os.environ.get("CI") != "true",
        reason="no chromium or pdftotext here (apt-get install chromium poppler-utils; .ci/run installs them)",
    ),
]
EXAMPLES = Path(__file__).resolve().parents[1] / "sessions" / "examples"
TOP = 0.2  # a table that starts in the top fifth of a page had the page to itself: if it splits, it must
TABLE = re.compile(r"<table>(.*?)</table>", re.S)
LEAD = re.compile(r"<p( [^>]*)?>([^<]*)</p>(\s*<div class=\"table\">)?\s*<table>")


def _marked(html: str) -> tuple[str, int, list[int]]:
    """The report with QQB<k> in table k's first cell, QQE<k> in its last, QQL<k> after the paragraph that
    introduces it; the number of tables and the tables introduced by a paragraph."""
    leads = [html[: m.start()].count("<table>") for m in LEAD.finditer(html)]
    html = LEAD.sub(
        lambda m: (
            f"<p{m.group(1) or ''}>{m.group(2)} QQL{html[: m.start()].count('<table>')}</p>{m.group(3) or ''}<table>"
        ),
        html,
    )
    count = 0

    def mark(m: re.Match) -> str:
        nonlocal count
        body = re.sub(r"<(t[hd])([^>]*)>", rf"<\1\2>QQB{count} ", m.group(1), count=1)
        end = body.rindex("</td>")
        body = f"{body[:end]} QQE{count}{body[end:]}"
        count += 1
        return f"<table>{body}</table>"

    html = TABLE.sub(mark, html)
    return html, count, leads


def _pages(pdf: Path) -> dict[str, tuple[int, float]]:
    """Each marker word: its page (from 0) and its top as a fraction of the page's height."""
    text = subprocess.run([PDFTOTEXT, "-bbox", str(pdf), "-"], capture_output=True, text=True, check=True).stdout
    found: dict[str, tuple[int, float]] = {}
    for k, page in enumerate(re.split(r"<page ", text)[1:]):
        height = float(re.match(r'width="[^"]+" height="([^"]+)"', page).group(1))
        for y, word in re.findall(r'<word xMin="[^"]+" yMin="([^"]+)"[^>]*>(QQ[BEL]\d+)</word>', page):
            found.setdefault(word, (k, float(y) / height))
    return found


@pytest.mark.long
@pytest.mark.parametrize("name", ["coebra_launch_vehicle", "coebra_lag_lead", "cip_launch_vehicle"])
def test_no_table_is_split_where_it_fits_on_a_page(name, tmp_path):
    folder = tmp_path / "examples"
    shutil.copytree(EXAMPLES, folder, ignore=shutil.ignore_patterns("*.py", "__pycache__"))
    assert main(["report", str(folder / f"{name}.json"), "--format", "html", "--out", str(tmp_path)]) == 0
    html, tables, leads = _marked((tmp_path / f"{name}.html").read_text())
    marked = tmp_path / "marked.html"
    marked.write_text(html)
    pdf = tmp_path / "report.pdf"
    assert CHROMIUM is not None, "CI=true: chromium must be installed (.ci/run installs it)"
    subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-pdf-header-footer",
            f"--print-to-pdf={pdf}",
            marked.as_uri(),
        ],
        capture_output=True,
        timeout=180,
        check=True,
    )
    at = _pages(pdf)
    assert tables > 5 and all(f"QQB{k}" in at and f"QQE{k}" in at for k in range(tables))
    split = [k for k in range(tables) if at[f"QQB{k}"][0] != at[f"QQE{k}"][0]]
    assert all(at[f"QQB{k}"][1] < TOP for k in split), [(k, at[f"QQB{k}"], at[f"QQE{k}"]) for k in split]
    assert leads and all(at[f"QQL{k}"][0] == at[f"QQB{k}"][0] for k in leads)

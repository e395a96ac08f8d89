"""The repository stands alone: no code, test or data file reaches into a
`shared` folder beside the checkout, and README.md links only to files that
exist in the repository."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("tests", "engine", "sessions", "tui")
TEXT_SUFFIXES = {".py", ".json", ".csv", ".md", ".toml"}
# written in two pieces so that this file does not match itself
SIBLING = ".." + "/shared"

LINK = re.compile(r"\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.MULTILINE | re.DOTALL)
CODE_SPAN = re.compile(r"`[^`\n]*`")
EXTERNAL = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")  # http:, https:, mailto:, ...


def text_files():
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*")):
            if path.is_file() and path.suffix in TEXT_SUFFIXES and "__pycache__" not in path.parts:
                yield path


def test_no_file_reaches_outside_the_repository():
    hits = []
    for path in text_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        if SIBLING not in text:
            continue
        for number, line in enumerate(text.splitlines(), start=1):
            if SIBLING in line:
                hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:160]}")
    assert not hits, f"{len(hits)} line(s) refer to {SIBLING}:\n" + "\n".join(hits)


def readme_links() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    text = CODE_SPAN.sub("", FENCE.sub("", text))
    return LINK.findall(text)


def test_readme_links_resolve():
    links = readme_links()
    assert links, "README.md has no links: the pattern no longer matches them"
    broken = []
    for link in links:
        if EXTERNAL.match(link) or link.startswith("#"):
            continue
        relative = link.split("#", 1)[0].split("?", 1)[0]
        target = (ROOT / relative).resolve()
        if not target.is_relative_to(ROOT):
            broken.append(f"{link}: outside the repository")
        elif not target.exists():
            broken.append(f"{link}: no such file")
    assert not broken, "README.md links to missing files:\n" + "\n".join(broken)

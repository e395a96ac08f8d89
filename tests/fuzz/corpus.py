"""The seed corpus: every bundled example with its CSV tables, as shipped and
after three iterations of its algorithm (so records and a state exist to edit)."""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"


@dataclass(frozen=True)
class Seed:
    """One document to mutate: its name, parsed JSON, and the tables it reads (name -> text)."""

    name: str
    doc: dict
    tables: dict[str, str]

    @property
    def has_history(self) -> bool:
        return bool(self.doc.get("records"))


def _tables(text: str) -> dict[str, str]:
    names = sorted(set(re.findall(r'"csv":\s*"([^"]+)"', text)))
    return {n: (EXAMPLES / n).read_text(encoding="utf-8") for n in names if (EXAMPLES / n).is_file()}


def _ran(path: Path, folder: Path) -> dict | None:
    """The example after `run --iterations 3` (None when that does not succeed)."""
    out = folder / f"ran_{path.name}"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        status = main(["run", str(path), "--iterations", "3", "--out", str(out)])
    return json.loads(out.read_text(encoding="utf-8")) if status == 0 and out.is_file() else None


def build_corpus() -> list[Seed]:
    """Every example, fresh and with three recorded iterations, in a stable order."""
    seeds: list[Seed] = []
    with tempfile.TemporaryDirectory(prefix="loopcraft-corpus-") as tmp:
        folder = Path(tmp)
        for f in EXAMPLES.iterdir():
            if f.suffix in (".json", ".csv"):
                shutil.copy2(f, folder / f.name)
        for path in sorted(folder.glob("*.json")):
            text = path.read_text(encoding="utf-8")
            tables = _tables(text)
            seeds.append(Seed(path.stem, json.loads(text), tables))
            ran = _ran(path, folder)
            if ran is not None:
                seeds.append(Seed(f"{path.stem}+3", ran, tables))
    return seeds

"""The app fuzzer: a mutated session opened in the workbench under Textual's pilot,
random keys pressed (ctrl+n among them: the new-session dialogs, digital loops' sample
times and holds) and random text typed into every dialog that asks for a line;
then the judgement: the app never died, and the session file on disk is either
as it was or a session that loads (never corrupted, never lost).

A case is drawn from (seed, index) alone, as the session fuzzer's are
(`tests.fuzz.harness`), so a failure is reproduced from the two numbers."""

from __future__ import annotations

import asyncio
import copy
import json
import os
import random
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from sessions.errors import SessionError
from sessions.store import load_session
from tests.fuzz.corpus import EXAMPLES
from tests.fuzz.mutator import Mutator

SESSION = "session.json"
# keys of the app, its tabs and tables, and of the dialogs (r runs to the end: n and s step instead)
KEYS = (
    "s", "s", "n", "z", "Z", "a", "p", "space", "u", "d", "y", "L", "question_mark", "escape", "escape",
    "1", "2", "3", "4", "5", "tab", "up", "down", "down", "left", "right", "enter", "enter",
    "e", "e", "plus", "minus", "f", "ctrl+s", "ctrl+o", "ctrl+z", "ctrl+y", "c", "x",
    "ctrl+n", "ctrl+n",  # the new-session dialogs (a plant, a structure, digital: a sample time, a hold)
)  # fmt: skip
TEXTS = (
    "", "0", "1", "3", "-5", "1e308", "nan", "inf", "K", "K + 1", "s/(s+1)", "1/(s", "\ud800",
    "x" * 300, "/" + "y" * 300 + ".json", "/dev/zero", "/tmp", "../../etc/passwd", "a\0b",
    "phase_margin_deg", "45", "0.5 1 2", "T1 >= 4*T2", "hz,mag,deg polar hz 1", "9" * 5000,
    "1e100", "5e-324", "0.1", "1/(s+1e300)", "exp(-0.3*s)/(s+1)", "10/(s*(s+1)*(s+5))",
)  # fmt: skip


@dataclass
class AppCase:
    """A drawn case: the example it mutates, the session text, the keys and texts to use."""

    seed: int
    index: int
    origin: str
    session: str
    keys: list[str]
    texts: list[str]
    log: list[str] = field(default_factory=list)

    def describe(self) -> str:
        return (
            f"case {self.index} of seed {self.seed} ({self.origin}): {'; '.join(self.log) or 'unmutated'}\n"
            f"  keys: {' '.join(self.keys)}\n"
            f"  reproduce: tests.fuzz.app_fuzz.run_case(draw_app_case({self.seed}, {self.index}), FOLDER)"
        )


def draw_app_case(seed: int, index: int, keys: int = 30) -> AppCase:
    """Case ``index`` of the app fuzz run ``seed`` (the same case every time)."""
    rng = random.Random(f"loopcraft-app-fuzz:{seed}:{index}")
    examples = sorted(EXAMPLES.glob("*.json"))
    origin = examples[index % len(examples)]
    doc = json.loads(origin.read_text(encoding="utf-8"))
    mutator = Mutator(rng)
    for _ in range(rng.choices((0, 1, 2), weights=(3, 5, 2))[0]):
        mutator.mutate(doc)
    return AppCase(
        seed,
        index,
        origin.stem,
        mutator.dumps(copy.deepcopy(doc)),
        [rng.choice(KEYS) for _ in range(keys)],
        [rng.choice(TEXTS) for _ in range(keys)],
        mutator.log,
    )


def _write(case: AppCase, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for table in EXAMPLES.glob("*.csv"):
        (folder / table.name).write_bytes(table.read_bytes())
    path = folder / SESSION
    path.write_text(case.session, encoding="utf-8")
    return path


async def _drive(case: AppCase, path: Path, budget: float) -> None:
    from textual.widgets import Input

    from tui.app import LoopcraftApp

    app = LoopcraftApp(path)
    end = time.monotonic() + budget
    async with app.run_test(size=(110, 36)) as pilot:
        await pilot.pause()
        for key, text in zip(case.keys, case.texts, strict=True):
            if time.monotonic() > end:
                break
            inputs = app.screen.query(Input)
            if inputs and key == "enter":
                inputs.first().value = text  # a dialog asks for a line: type the case's text
            await pilot.press(key)
            await pilot.pause()
        await pilot.press("space")  # a run still going stops before the app does
        await pilot.pause()
        app.exit()


def _file_verdict(path: Path, before: bytes) -> str | None:
    """Why the session file is lost or corrupted, or None."""
    if not path.exists():
        return "the session file is gone"
    after = path.read_bytes()
    if after == before:
        return None
    try:
        load_session(path)
    except SessionError as exc:
        return f"the session file was rewritten and no longer loads: {exc}"
    return None


def run_case(case: AppCase, folder: Path, budget: float = 20.0) -> str | None:
    """Run one case in ``folder``; the failure in words, or None."""
    home = os.environ.get("LOOPCRAFT_HOME")
    os.environ["LOOPCRAFT_HOME"] = str(folder / "home")
    path = _write(case, folder)
    before = path.read_bytes()
    try:
        asyncio.run(_drive(case, path, budget))
    except Exception as exc:  # noqa: BLE001 -- an app death is what the fuzzer looks for
        frames = traceback.format_exception(exc)
        return f"the app died: {type(exc).__name__}: {str(exc)[:300]}\n" + "".join(frames[-6:])
    finally:
        if home is None:
            os.environ.pop("LOOPCRAFT_HOME", None)
        else:
            os.environ["LOOPCRAFT_HOME"] = home
    return _file_verdict(path, before)

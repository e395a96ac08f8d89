"""One fuzz case: draw it from (seed, index), write it to a folder, run the
CLI's `main()` on it in-process, and judge what happened.

A case passes when no exception escapes `main()`, the exit status is 0 or 2
(1 only from `replay`), a status 2 comes with an error message, the files
it read are unchanged, no RuntimeWarning was emitted, it ended within its
time budget, and a successful `run` saved a session that loads again."""

from __future__ import annotations

import contextlib
import copy
import io
import random
import signal
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from sessions.errors import SessionError
from sessions.store import load_session
from tests.fuzz.corpus import Seed
from tests.fuzz.mutator import Mutator
from tests.fuzz.tables import garble_csv
from tui.cli import main

SESSION = "session.json"
OUT = "out.json"
PROJECT = ("engine", "sessions", "tui")
REPORTS = ([], [], [], [], [], ["--format", "json"], ["--format", "csv"], ["--iteration", "0"])


class Hang(BaseException):
    """The case ran past its time budget (a BaseException: nothing in the project swallows it)."""


@dataclass
class Case:
    """A drawn case: which seed, which command, the files to write, and what was mutated."""

    seed: int
    index: int
    origin: str
    command: str
    options: list[str]
    session: str
    tables: dict[str, str | bytes]
    log: list[str]

    def argv(self, folder: Path) -> list[str]:
        """The command line, with the case's files in ``folder``."""
        path = str(folder / SESSION)
        if self.command == "run":
            return ["run", path, "--iterations", "3", "--out", str(folder / OUT)]
        return [self.command, path, *self.options]


@dataclass
class Outcome:
    """What a case did: ``kind`` is ok, error or diverged, or a failure's kind."""

    case: Case
    kind: str
    seconds: float
    signature: str = ""
    detail: str = ""
    stderr: str = ""
    warnings: list[str] = field(default_factory=list)

    @property
    def failed(self) -> bool:
        return self.kind not in ("ok", "error", "diverged")

    def describe(self) -> str:
        """Everything needed to see and reproduce the failure."""
        return (
            f"[{self.kind}] {self.signature}\n  case {self.case.index} of seed {self.case.seed} "
            f"({self.case.origin}, {self.case.command} {' '.join(self.case.options)}): "
            f"{'; '.join(self.case.log) or 'unmutated'}\n"
            f"  reproduce: .venv/bin/python -m tests.fuzz --seed {self.case.seed} --case {self.case.index} -v\n"
            + "".join(f"  {line}\n" for line in self.detail.strip().splitlines()[-12:])
        )


def draw(seeds: list[Seed], seed: int, index: int) -> Case:
    """Case ``index`` of the fuzz run ``seed`` (the same case every time)."""
    rng = random.Random(f"loopcraft-fuzz:{seed}:{index}")
    origin = seeds[index % len(seeds)]
    doc = copy.deepcopy(origin.doc)
    mutator = Mutator(rng)
    tables: dict[str, str | bytes] = dict(origin.tables)
    garble = bool(tables) and rng.random() < 0.2
    if garble:
        name = rng.choice(sorted(tables))
        tables[name], what = garble_csv(rng, origin.tables[name])
        mutator.log.append(f"{name}: {what}")
    count = rng.choices((0, 1, 2, 3), weights=(1 if not garble else 10, 12, 5, 3))[0]
    for _ in range(count):
        if origin.has_history and rng.random() < 0.4:
            mutator.edit_history(doc)
        else:
            mutator.mutate(doc)
    command = rng.choices(("report", "run", "replay"), weights=(60, 25, 15))[0]
    options = list(rng.choice(REPORTS)) if command == "report" else []
    return Case(seed, index, origin.name, command, options, mutator.dumps(doc), tables, mutator.log)


def _write(case: Case, folder: Path) -> dict[Path, bytes]:
    """The case's files in ``folder``; their bytes, to check they are left alone."""
    folder.mkdir(parents=True, exist_ok=True)
    files = {folder / SESSION: case.session.encode("utf-8")}
    for name, text in case.tables.items():
        files[folder / name] = text if isinstance(text, bytes) else text.encode("utf-8")
    for path, data in files.items():
        path.write_bytes(data)
    return files


def _where(exc: BaseException) -> str:
    """The innermost frame of the project's own code in the exception's traceback."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if any(f"/{p}/" in f.filename for p in PROJECT)]
    if not frames:
        return "?"
    f = frames[-1]
    parts = Path(f.filename).parts
    start = max(i for i, p in enumerate(parts) if p in PROJECT)
    return f"{'/'.join(parts[start:])}:{f.name}"


def _alarm(signum, frame) -> None:
    raise Hang()


def execute(case: Case, folder: Path, budget: float) -> Outcome:
    """Run the case's command in ``folder`` and judge it."""
    files = _write(case, folder)
    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    began = time.perf_counter()
    status, escaped = None, None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        signal.setitimer(signal.ITIMER_REAL, budget)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                status = main(case.argv(folder))
        except BaseException as exc:  # noqa: BLE001 -- that is what the fuzzer looks for
            escaped = exc
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
    seconds = time.perf_counter() - began
    outcome = Outcome(case, "ok", seconds, stderr=err.getvalue())
    outcome.warnings = [
        f"{w.category.__name__}: {Path(w.filename).name}:{w.lineno}: {w.message}"
        for w in caught
        if issubclass(w.category, RuntimeWarning)
    ]
    _judge(outcome, status, escaped, files, folder)
    return outcome


def _judge(outcome: Outcome, status, escaped, files: dict[Path, bytes], folder: Path) -> None:
    """Set the outcome's kind, signature and detail from what the command did."""
    command = outcome.case.command
    if isinstance(escaped, KeyboardInterrupt):
        raise escaped
    if escaped is not None:
        kind = "hang" if isinstance(escaped, Hang) else "traceback"
        name = f"after {outcome.seconds:.1f} s" if kind == "hang" else type(escaped).__name__
        outcome.kind, outcome.signature = kind, f"{name} in {_where(escaped)}"
        outcome.detail = "".join(traceback.format_exception(escaped))
        return
    changed = [p.name for p, data in files.items() if not p.is_file() or p.read_bytes() != data]
    if status not in (0, 1, 2) or (status == 1 and command != "replay"):
        outcome.kind, outcome.signature = "status", f"exit status {status!r} from {command}"
    elif changed:
        outcome.kind, outcome.signature = "changed", f"{command} changed {', '.join(changed)}"
    elif status == 2 and "error:" not in outcome.stderr:
        outcome.kind, outcome.signature = "silent", f"{command} failed without a message"
    elif outcome.warnings:
        outcome.kind, outcome.signature = "warning", outcome.warnings[0][:160]
        outcome.detail = "\n".join(outcome.warnings)
    elif status == 0 and command == "run":
        _check_saved(outcome, folder / OUT)
    if not outcome.failed:
        outcome.kind = {0: "ok", 1: "diverged", 2: "error"}[status]


def _check_saved(outcome: Outcome, path: Path) -> None:
    """A successful run's saved session must load again."""
    try:
        load_session(path)
    except SessionError as exc:
        outcome.kind, outcome.signature = "reload", f"saved session does not load: {str(exc)[:120]}"
    except Exception as exc:  # noqa: BLE001
        outcome.kind, outcome.signature = "reload", f"{type(exc).__name__} loading the saved session in {_where(exc)}"
        outcome.detail = "".join(traceback.format_exception(exc))

"""The command fuzzer's cases (issue 50's new surface): `set` and `tune` on a session with
extreme values and names, `export` and `report` onto every kind of target (the session
itself, its table, a hard link, a FIFO, a folder, an existing file, with and without
--force), discretized blocks and sample times in `analyze --held` and `new
--sample-time`, and state-space plants.  Each case is drawn from (seed, index) and judged
as `tests.fuzz.harness` judges a session case, plus: an input is changed only by a
command that updates its session in place by design, a FIFO stays a FIFO, an existing
file is replaced only with --force, and an error is one line."""

from __future__ import annotations

import contextlib
import io
import os
import random
import shutil
import signal
import stat
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from tests.fuzz.harness import Hang, _alarm, _where
from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "sessions" / "examples"
SESSIONS = ("report003_lag_lead.json", "seidel_inlet_pi.json", "coebra_kuo_z.json", "lead_sensitivity_peak.json")
NUMBERS = ("0", "-1", "1e308", "-1e308", "5e-324", "1e-320", "nan", "inf", "1e9", "0.5", "2", "1e-300", "3")
NAMES = ("K", "z1", "p2", "Kp", "Ki", "compensator.zero1", "compensator.pole1", "compensator.gain", "b21", "x" * 300)
EXPRESSIONS = ("1/(s+1)", "1/(s+1e300)", "1/(s^2+1e-300*s+1)", "exp(-0.1*s)/(s+1)", "(s+1)/(s+2)", "1e308/(s+1)")
TARGETS = ("session", "table", "link", "fifo", "folder", "existing", "new")
IN_PLACE = ("set", "tune")  # commands that update their session in place when given no --out


@dataclass
class CommandCase:
    """A drawn case: its command line (with {folder} for the case's folder) and its target."""

    seed: int
    index: int
    session: str
    argv: list[str]
    target: str = ""
    force: bool = False
    log: list[str] = field(default_factory=list)


def draw(seed: int, index: int) -> CommandCase:
    """Case ``index`` of the command fuzz run ``seed`` (the same case every time)."""
    rng = random.Random(f"loopcraft-command-fuzz:{seed}:{index}")
    session = SESSIONS[index % len(SESSIONS)]
    kind = rng.choice(("set", "tune", "export", "report", "analyze", "new", "analyze_ss"))
    force = rng.random() < 0.5
    target = rng.choice(TARGETS) if kind in ("export", "set", "tune") and rng.random() < 0.7 else ""
    target = rng.choice(("fifo", "existing", "new")) if kind == "report" else target
    path = "{folder}/" + session
    if kind == "set":
        op = rng.choice(("=", "*=", "*=+"))
        unit = "dB" if op == "*=+" else ""
        argv = [
            "set",
            path,
            f"{rng.choice(NAMES)}{op.rstrip('+')}{'+' if op == '*=+' else ''}{rng.choice(NUMBERS)}{unit}",
        ]
    elif kind == "tune":
        argv = ["tune", path, "--gain-for", f"{rng.choice(('crossover', 'pm'))}={rng.choice(NUMBERS)}"]
    elif kind == "export":
        argv = ["export", path, "--to", rng.choice(("python", "matlab", "json", "csv"))]
        argv += ["--fit"] if rng.random() < 0.2 else []
    elif kind == "report":
        argv = ["report", path, "--format", rng.choice(("html", "md"))]
    elif kind == "analyze":
        argv = ["analyze", "--variable", "z", "--tf", "1", "--sample-time", rng.choice(NUMBERS)]
        argv += ["--held", rng.choice(EXPRESSIONS), "--discretize", rng.choice(("zoh", "tustin", "matched"))]
        argv += ["--delay", rng.choice(NUMBERS)] if rng.random() < 0.3 else []
    elif kind == "new":
        argv = ["new", "{folder}/new.json", "--plant", rng.choice(EXPRESSIONS), "--sample-time", rng.choice(NUMBERS)]
        argv += ["--discretize", rng.choice(("zoh", "tustin", "matched"))]
    else:
        scale = rng.choice(NUMBERS)
        argv = ["analyze", "--ss", "{folder}/plant.json", "--tf", f"{rng.choice(NUMBERS)}*(s+1)/(s+{scale})"]
    if target:
        argv += ["--out", "{folder}" if kind == "report" else "{target}"]
    argv += ["--force"] if force and (target or kind == "new") else []
    return CommandCase(seed, index, session, argv, target, force, [kind])


def _prepare(case: CommandCase, folder: Path) -> tuple[list[str], dict[Path, bytes], Path | None]:
    """The case's files in ``folder`` and its command line; the inputs' bytes; the target
    (a report's: the file it writes in ``folder``)."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(EXAMPLES / case.session, folder / case.session)
    if case.session == "seidel_inlet_pi.json":  # the one session here that reads a table
        shutil.copy(EXAMPLES / "seidel_inlet_table1.csv", folder / "seidel_inlet_table1.csv")
    (folder / "plant.json").write_text('{"A": [[0, 1], [-1e300, -1e-300]], "B": [0, 1], "C": [1, 0], "D": 0}')
    inputs = {p: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    session = folder / case.session
    written = folder / (Path(case.session).stem + (".html" if "html" in case.argv else ".md"))
    target = {
        "session": session,
        "table": folder / "seidel_inlet_table1.csv",
        "link": folder / "link.json",
        "fifo": folder / "pipe",
        "folder": folder,
        "existing": folder / "existing.out",
        "new": folder / "fresh.out",
    }.get(case.target)
    if case.argv[0] == "report" and case.target in ("fifo", "existing"):
        target = written
    if case.target == "link":
        os.link(session, folder / "link.json")
    elif case.target == "fifo":
        os.mkfifo(target)
    elif case.target == "existing":
        target.write_text("kept")
    argv = [a.replace("{folder}", str(folder)).replace("{target}", str(target)) for a in case.argv]
    return argv, inputs, target


@dataclass
class CommandOutcome:
    case: CommandCase
    kind: str
    signature: str = ""
    detail: str = ""

    @property
    def failed(self) -> bool:
        return self.kind not in ("ok", "error")

    def describe(self) -> str:
        return (
            f"[{self.kind}] {self.signature}\n  case {self.case.index} of seed {self.case.seed}: "
            f"loopcraft {' '.join(self.case.argv)}\n"
            + "".join(f"  {line}\n" for line in self.detail.splitlines()[-12:])
        )


def execute(case: CommandCase, folder: Path, budget: float) -> CommandOutcome:
    """Run the case's command in ``folder`` and judge it."""
    argv, inputs, target = _prepare(case, folder)
    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    status, escaped = None, None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        signal.setitimer(signal.ITIMER_REAL, budget)
        began = time.perf_counter()
        try:
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                status = main(argv)
        except SystemExit as exc:  # argparse's refusal
            status = exc.code
        except BaseException as exc:  # noqa: BLE001 -- that is what the fuzzer looks for
            escaped = exc
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
    if isinstance(escaped, KeyboardInterrupt):
        raise escaped
    if escaped is not None:
        kind = "hang" if isinstance(escaped, Hang) else "traceback"
        name = f"after {time.perf_counter() - began:.1f} s" if kind == "hang" else type(escaped).__name__
        return CommandOutcome(case, kind, f"{name} in {_where(escaped)}", "".join(traceback.format_exception(escaped)))
    return _judge(case, status, err.getvalue(), caught, inputs, target)


def _judge(case, status, stderr: str, caught, inputs: dict[Path, bytes], target) -> CommandOutcome:
    command = case.argv[0]
    in_place = command in IN_PLACE and not case.target
    changed = [
        p.name
        for p, data in inputs.items()
        if (not p.is_file() or p.read_bytes() != data) and not (in_place and p.name == case.session)
    ]
    runtime = [
        f"{w.category.__name__}: {Path(w.filename).name}:{w.lineno}: {w.message}"
        for w in caught
        if not issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning))
    ]
    if status not in (0, 2):
        return CommandOutcome(case, "status", f"exit status {status!r} from {command}")
    if status == 2 and (stderr.count("\n") != 1 or "error:" not in stderr):
        return CommandOutcome(case, "message", f"{command}: not one error line", stderr[:600])
    if changed:
        return CommandOutcome(case, "changed", f"{command} changed {', '.join(changed)}")
    if case.target == "fifo" and not stat.S_ISFIFO(target.lstat().st_mode):
        return CommandOutcome(case, "changed", f"{command} replaced a FIFO")
    if case.target == "existing" and not case.force and target.read_text() != "kept":
        return CommandOutcome(case, "changed", f"{command} replaced an existing file without --force")
    inputs_named = ("session", "link") + (("table",) if case.session == "seidel_inlet_pi.json" else ())
    if case.target in inputs_named and status != 2:
        return CommandOutcome(case, "changed", f"{command} --out onto an input of the command exited {status}")
    if runtime:
        return CommandOutcome(case, "warning", runtime[0][:160], "\n".join(runtime))
    return CommandOutcome(case, {0: "ok", 2: "error"}[status])

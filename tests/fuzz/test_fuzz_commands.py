"""Fuzz the commands issue 50 added surface to (`tests.fuzz.commands`): set, tune, export and
report onto every kind of target, discretized blocks and sample times, state-space plants.

`make test` runs LOOPCRAFT_FUZZ_COMMAND_CASES (default 30) seeded cases; `make fuzz` 2000.
A failure prints its seed and case and the command line that reproduces it."""

from __future__ import annotations

import pytest

from tests.fuzz.campaign import DEFAULT_BUDGET, DEFAULT_SEED, setting
from tests.fuzz.commands import draw, execute

CASES = int(setting("COMMAND_CASES", 30))
SEED = int(setting("SEED", DEFAULT_SEED))
BUDGET = float(setting("BUDGET", DEFAULT_BUDGET))


def test_commands_on_extreme_input_and_every_target_never_crash_or_lose_a_file(tmp_path):
    failures = {}
    for index in range(CASES):
        outcome = execute(draw(SEED, index), tmp_path / str(index), BUDGET)
        if outcome.failed:
            failures.setdefault(outcome.signature, []).append(outcome)
    if failures:
        pytest.fail(
            f"{sum(map(len, failures.values()))} failing case(s) of {CASES}:\n"
            + "\n".join(f"{len(o)} x {o[0].describe()}" for o in failures.values()),
            pytrace=False,
        )


def test_the_command_fuzzer_sees_a_lost_file(tmp_path, monkeypatch):
    """A command that replaces its own session through --out is reported, not passed over."""
    from sessions.format import save_file
    from tests.fuzz import commands

    monkeypatch.setattr(save_file, "check_output", lambda *args, **kwargs: None)
    case = commands.CommandCase(SEED, 0, "report003_lag_lead.json", ["export", "{folder}/report003_lag_lead.json"])
    case.argv += ["--to", "python", "--out", "{target}"]
    case.target = "session"
    outcome = execute(case, tmp_path, BUDGET)
    assert outcome.kind == "changed" and "report003_lag_lead.json" in outcome.signature

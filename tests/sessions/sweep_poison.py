"""A stand-in for `sessions.sweeps.jobs.run_batch` whose run of job `POISON` kills
its worker process (imported by the workers of tests/sessions/test_sweep_batches.py)."""

from __future__ import annotations

import os

from sessions.sweeps.jobs import run_batch

POISON = 5


def poisoned(payloads: list[dict]) -> list[dict]:
    if any(payload["index"] == POISON for payload in payloads):
        os._exit(1)
    return run_batch(payloads)

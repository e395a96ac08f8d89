"""Stand-ins for `sessions.sweeps.jobs.run_batch` and `sessions.sweeps.study_chunks.evaluate_chunk`
whose run of job (or sample) `POISON` kills its worker process (imported by the workers of
tests/sessions/test_sweep_batches.py and test_study_chunks.py), or, on an in-process worker,
hangs until `RELEASE` is set."""

from __future__ import annotations

import os
import threading

from sessions.sweeps.jobs import run_batch
from sessions.sweeps.study_chunks import evaluate_chunk

POISON = 5
RELEASE = threading.Event()  # `hung_chunk`'s poisoned chunk returns once it is set


def poisoned(payloads: list[dict]) -> list[dict]:
    if any(payload["index"] == POISON for payload in payloads):
        os._exit(1)
    return run_batch(payloads)


def poisoned_chunk(key: str, samples, task: str, split: int = 0, probe: int = 0):
    if POISON in samples.indices:
        os._exit(1)
    return evaluate_chunk(key, samples, task, split, probe)


def hung_chunk(key: str, samples, task: str, split: int = 0, probe: int = 0):
    if POISON in samples.indices:
        RELEASE.wait()
    return evaluate_chunk(key, samples, task, split, probe)

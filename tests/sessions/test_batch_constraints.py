"""Issue 53, section 1: sessions with linear constraints between parameters are batched.
A tolerance study's samples are the parts as built: the constraints limit the designer's
choices, not the parts' spread, so the study's document leaves them out (98f0f04) and a
constrained session's study goes by the batch like any other.  Random leads, lags,
lead-lags and PIDs on random plants, with random constraints (some binding at the design, some not), every
run equal to the per-loop path's (`run_job`) to 1e-12 relative."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sessions.new.templates import new_session
from sessions.store import load_session
from sessions.sweeps.batch_study import batch_runs
from sessions.sweeps.jobs import run_job
from sessions.sweeps.plan import plan
from tests.sessions.test_batch_study import _same_run


def _random_session(rng: np.random.Generator, tmp_path, k: int):
    """A lead, lag, lead-lag or PID on a random plant k/(s (s + a)(s + b)), its parameters set where
    random constraints hold, some of them binding; the path and the tolerances."""
    a, b = np.exp(rng.uniform(np.log(0.3), np.log(30.0), 2))
    kind = ("lead", "lag", "lead-lag", "pid")[k % 4]
    model = new_session(f"{rng.uniform(1, 20):.6g}/(s*(s+{a:.6g})*(s+{b:.6g}))", kind)
    entries = {p["name"]: p for p in model["problem"]["parameters"]}
    times = sorted(name for name in entries if name.startswith("T"))
    for name in times:
        entries[name]["value"] = float(np.exp(rng.uniform(np.log(0.05), np.log(5.0))))
    entries["K"]["value"] = float(np.exp(rng.uniform(np.log(0.1), np.log(10.0))))
    first, second = times[0], times[1]
    ratio = entries[first]["value"] / entries[second]["value"]
    binding = f"{first} <= {ratio:.17g}*{second}"  # holds with equality at the design
    loose = f"{first} + {second} <= {2 * (entries[first]['value'] + entries[second]['value']):.17g}"
    model["problem"]["constraints"] = [binding, loose]
    path = tmp_path / f"constrained{k}.json"
    path.write_text(json.dumps(model))
    return path, [f"{name}=+-10%" for name in ["K", *times]]


@pytest.mark.parametrize("seed", range(8))
def test_random_constrained_sessions_are_batched_and_equal_the_per_loop_path(tmp_path, seed):
    rng = np.random.default_rng(seed)
    path, tolerances = _random_session(rng, tmp_path, seed)
    session = load_session(path)
    assert session.model.problem.constraints  # the session is constrained; its study is not
    jobs = plan(session, "tolerance", tolerances, None, seed, 40, "lhs")[0]
    batch = batch_runs(jobs)
    assert batch is not None and batch.per_loop == 0, None if batch is None else batch.per_loop
    assert batch.done == len(jobs)
    for got, job in zip(batch.runs, jobs, strict=True):
        _same_run(got, run_job(job.payload()))

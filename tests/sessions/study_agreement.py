"""A study's runs on workers against the same study run serially.  A serial tolerance study is
batched (`sessions.sweeps.batch_study`: the samples' closed loops in one array) while a worker
runs each sample by the per-loop path (`sessions.sweeps.jobs.run_job`), so their numbers agree
to rounding, not bit for bit (the lag-lead's stability abscissa: 2e-15 relative apart): issue
53 asks them equal to 1e-12."""

from __future__ import annotations

import math

REL = 1e-12


def assert_measures_agree(ours: list[list[dict]], serial: list[list[dict]]) -> None:
    """Each run's rows: the same names, verdicts and fields, numbers to `REL` relative."""
    assert len(ours) == len(serial)
    for run, (mine, theirs) in enumerate(zip(ours, serial)):
        assert [r["name"] for r in mine] == [r["name"] for r in theirs], run
        for a, b in zip(mine, theirs):
            assert a.keys() == b.keys() and a["satisfied"] == b["satisfied"], (run, a, b)
            for key in a:
                x, y = a[key], b[key]
                if isinstance(x, float) and isinstance(y, float) and math.isfinite(x) and math.isfinite(y):
                    assert math.isclose(x, y, rel_tol=REL, abs_tol=1e-300), (run, key, x, y)
                else:
                    assert x == y, (run, key, x, y)

"""A tolerance study counts every sample (issue 50): a sample is evaluated whatever the
design's constraints between parameters (a design constraint limits the designer's choices,
not the parts' spread); a sample that cannot be evaluated is a result with its reason,
counted per reason; the summary's first line says over how many samples its statistics are."""

from __future__ import annotations

import json

from sessions.sweeps.dispersion import Tally
from tui.cli import main
from tui.cli.sweep import sweep_text

STUDY = ["--tolerance", "K=normal:20%", "--tolerance", "T1=uniform:30%", "--tolerance", "T2=+-30%"]


def test_a_design_constraint_leaves_no_sample_out(tmp_path, capsys):
    """The lead of `loopcraft new` keeps T1 <= 20*T2; at T1 = 2, T2 = 0.1 it binds, and
    about half the samples broke it: 197 of 400 were refused, the statistics taken over the
    other 203 (a biased half)."""
    path = tmp_path / "lead.json"
    assert main(["new", str(path), "--plant", "1/(s*(s+1))", "--compensator", "lead"]) == 0
    assert main(["set", str(path), "T1=2"]) == 0
    assert "T1 <= 20*T2" in json.loads(path.read_text())["problem"]["constraints"]
    capsys.readouterr()
    argv = ["sweep", str(path), *STUDY, "--samples", "400", "--sampling", "lhs", "--seed", "7", "--serial", "--json"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    broken = [r for r in summary["runs"] if r["start"]["T1"] > 20 * r["start"]["T2"]]
    assert len(broken) > 100  # the samples the constraint refused, now evaluated
    assert summary["failed"] == [] and summary["excluded"] == {}
    assert all(row["samples"] == 400 for row in summary["worst_case"])
    assert "T1 <= 20*T2" in json.loads(path.read_text())["problem"]["constraints"]  # the design keeps it


def _run(index: int, failed: str | None = None) -> dict:
    if failed:
        return {
            "index": index,
            "label": f"sample {index}",
            "status": "failed",
            "reason": failed,
            "start": {"K": 1.0},
            "ranking": None,
            "meets_requirements": False,
            "measures": [],
        }
    measure = {"name": "PM1", "kind": "phase_margin_deg", "condition": "nominal", "desired": 45.0}
    return {
        "index": index,
        "label": f"sample {index}",
        "status": "running",
        "reason": "",
        "start": {"K": 1.0 + index},
        "ranking": 1.0,
        "meets_requirements": True,
        "measures": [{**measure, "at_least": True, "value": 50.0 + index, "satisfied": True}],
    }


def test_samples_that_cannot_be_evaluated_are_counted_per_reason_and_said_first():
    reasons = ["the closed loop is singular", "the closed loop is singular", "no crossover found"]
    runs = [_run(k, reasons[k % 5] if k % 5 < 3 else None) for k in range(10)]
    tally = Tally.of(runs)
    assert dict(tally.excluded) == {"the closed loop is singular": 4, "no crossover found": 2}
    summary = {
        "kind": "tolerance",
        "workers": 1,
        "runs": tally.runs(),
        "failed": list(tally.failed),
        "excluded": dict(tally.excluded.most_common()),
        "retried": {},
        "settings": {"samples": 10},
        "worst_case": tally.rows(),
    }
    first = sweep_text(summary).splitlines()[0]
    assert first == (
        "tolerance sweep: 10 runs on 1 worker(s), statistics over 4 of 10 samples, 6 excluded "
        "(4: the closed loop is singular; 2: no crossover found), 0 retried"
    )
    assert summary["worst_case"][0]["samples"] == 4

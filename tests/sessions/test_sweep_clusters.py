"""Sweeps beyond one machine (issue 41, section 3): a cluster named in Dask's own
configuration (dask-jobqueue's jobqueue.yaml profiles for SLURM, PBS, SGE and LSF, or
the local one), the job script it would submit, bad names and profiles as one line,
and short runs sent in batches sized from a first chunk timed on the cluster.  A
worker killed midway: tests/sessions/test_sweep_worker_loss.py."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import dask
import dask_jobqueue  # noqa: F401 - its defaults in Dask's configuration, under the profiles the tests set
import pytest

from sessions.errors import SessionError
from sessions.store import load_session
from sessions.sweeps import named_clusters
from sessions.sweeps.cluster import QUIET_WORKERS
from sessions.sweeps.jobs import execute, execute_serial
from sessions.sweeps.named_clusters import named_cluster, quiet_exports
from sessions.sweeps.plan import tolerance_jobs
from tests.sessions.study_agreement import assert_measures_agree
from tui.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "sessions" / "examples"
PROFILE = {"cores": 2, "memory": "4GB", "walltime": "01:00:00"}


def _profile(name: str, **settings) -> dict:
    """Settings of jobqueue.NAME over dask-jobqueue's defaults, for dask.config.set."""
    return {f"jobqueue.{name}.{key}": value for key, value in {**PROFILE, **settings}.items()}


def _copy(tmp_path: Path) -> Path:
    shutil.copy(EXAMPLES / "coebra_lag_lead.json", tmp_path / "s.json")
    return tmp_path / "s.json"


@pytest.mark.slow
def test_the_job_script_comes_from_a_jobqueue_yaml(tmp_path):
    """`sweep --cluster slurm --print-job-script` in a process of its own, its profile
    read by Dask from a jobqueue.yaml (DASK_CONFIG), no batch system needed."""
    (tmp_path / "jobqueue.yaml").write_text(
        "jobqueue:\n  slurm:\n    cores: 4\n    memory: 8GB\n    queue: short\n    walltime: '02:00:00'\n"
    )
    done = subprocess.run(
        [sys.executable, "-m", "tui.cli", "sweep", "s.json", "--cluster", "slurm", "--print-job-script"],
        cwd=ROOT,
        env={**os.environ, "DASK_CONFIG": str(tmp_path)},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    script = done.stdout
    for line in ("#SBATCH -p short", "#SBATCH --cpus-per-task=4", "#SBATCH --mem=8G", "#SBATCH -t 02:00:00"):
        assert line in script.splitlines()
    assert "-m distributed.cli.dask_worker tcp://" in script
    assert "--nthreads 1" in script and "--nworkers 4" in script  # one thread a process: the runs hold the GIL
    assert all(line in script.splitlines() for line in quiet_exports())


@pytest.mark.parametrize(
    ("name", "directive"), [("slurm", "#SBATCH"), ("pbs", "#PBS"), ("sge", "#$"), ("lsf", "#BSUB")]
)
def test_each_batch_system_prints_its_job_script(name, directive, capsys):
    with dask.config.set(_profile(name)):
        assert main(["sweep", "s.json", "--cluster", name, "--print-job-script"]) == 0
    script = capsys.readouterr().out
    assert script.startswith("#!") and directive in script and "distributed.cli.dask_worker" in script


def test_the_job_script_makes_its_workers_quiet():
    """The exports in the job script set `QUIET_WORKERS` in the workers' Dask configuration."""
    environ = dict(line.removeprefix("export ").split("=", 1) for line in quiet_exports())
    collected = dask.config.collect_env(environ)
    for key, value in QUIET_WORKERS.items():
        assert dask.config.get(key, config=collected) == value


BAD = [
    (["--cluster", "torque", "--starts", "2"], "--cluster 'torque': one of local, slurm, pbs, sge, lsf"),
    (
        ["--cluster", "slurm", "--starts", "2"],
        "--cluster slurm: You must specify how much cores and memory",
    ),
    (["--cluster", "slurm", "--print-job-script"], "jobqueue.slurm.*"),
    (["--cluster", "local", "--print-job-script"], "--print-job-script: a local cluster has no job script"),
    (["--cluster", "local", "--max-jobs", "2", "--starts", "2"], "--min-jobs and --max-jobs are for a batch system"),
    (["--max-jobs", "2", "--starts", "2"], "--min-jobs, --max-jobs and --print-job-script are for --cluster NAME"),
    (["--cluster", "slurm", "--min-jobs", "3", "--max-jobs", "2"], "--cluster slurm: 3 to 2 jobs"),
    (["--cluster", "slurm"], "one of --starts, --vary, --tolerance is required"),
]


@pytest.mark.parametrize(("options", "message"), BAD, ids=[" ".join(o) for o, _ in BAD])
def test_a_bad_name_or_profile_is_one_line_and_exit_status_2(options, message, tmp_path, capsys):
    path = _copy(tmp_path)
    assert main(["sweep", str(path), *options]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.splitlines()) == 1, err
    assert not json.loads(path.read_text()).get("sweeps")


def test_a_batch_system_is_not_sized_by_workers(tmp_path, capsys):
    path = _copy(tmp_path)
    with dask.config.set(_profile("slurm")):
        assert main(["sweep", str(path), "--cluster", "slurm", "--workers", "2", "--starts", "2"]) == 2
    assert "--workers sizes a local cluster; a slurm cluster's size is --max-jobs" in capsys.readouterr().err


def test_the_bounds_of_the_jobs_come_from_the_options_else_the_profile():
    assert named_cluster("slurm") == named_clusters.NamedCluster("slurm", 0, 1)
    with dask.config.set({"jobqueue.pbs.minimum-jobs": 2, "jobqueue.pbs.maximum-jobs": 20}):
        assert named_cluster(" PBS ") == named_clusters.NamedCluster("pbs", 2, 20)
        assert named_cluster("pbs", max_jobs=4) == named_clusters.NamedCluster("pbs", 2, 4)
    with dask.config.set({"jobqueue.lsf.maximum-jobs": "many"}), pytest.raises(SessionError, match="whole number"):
        named_cluster("lsf")
    assert named_cluster("local") == named_clusters.NamedCluster("local")


@pytest.mark.long
@pytest.mark.slow
def test_an_adaptive_jobqueue_cluster_runs_a_study_in_batches(tmp_path, monkeypatch):
    """dask-jobqueue's own LocalCluster (its jobs are processes here) in place of SLURM's,
    scaled adaptively up to two jobs: the study's samples go in chunks, the first ones
    timed on it and the rest sized for the two workers it may have."""
    from dask_jobqueue.local import LocalCluster

    monkeypatch.setattr(dask_jobqueue, "SLURMCluster", LocalCluster)
    monkeypatch.setattr(named_clusters, "quiet_exports", list)  # its jobs run the command alone, no script
    jobs = tolerance_jobs(load_session(_copy(tmp_path)), ["T1=+-10%"], 200, seed=3)
    with dask.config.set(
        _profile("slurm", cores=1, memory="1GB", **{"scheduler-options": {"dashboard_address": ":0"}})
    ):
        outcome = execute(jobs, cluster=named_cluster("slurm", 0, 2))
    assert not outcome.serial and all(r["worker"].startswith("tcp://") for r in outcome.runs)
    sizes = outcome.note.split(" chunks of ")[1].split()[0]
    assert 1 < int(sizes.split("-")[-1]) <= 200 // 4, outcome.note  # at least two chunks per worker it may have
    assert_measures_agree([r["measures"] for r in outcome.runs], [r["measures"] for r in execute_serial(jobs).runs])

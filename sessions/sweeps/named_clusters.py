"""A cluster named by ``loopcraft sweep --cluster NAME``, as Dask's own configuration
describes it: ``local`` (`sessions.sweeps.cluster.local_cluster`), or a batch
system's through dask-jobqueue (``slurm``, ``pbs``, ``sge``, ``lsf``: the
``jobqueue.NAME`` section of a jobqueue.yaml, read as dask-jobqueue reads it),
scaled adaptively between a minimum and a maximum of jobs.  A batch system's
workers run one thread a process unless ``processes`` is configured (the runs
hold the GIL), and are quiet as a local cluster's are (`QUIET_WORKERS`, set by
environment variables in the job script).  Every failure is a `SessionError`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from sessions.errors import SessionError
from sessions.sweeps.cluster import QUIET_WORKERS, Connection, close, cluster_client, connect, reason

if TYPE_CHECKING:
    from dask_jobqueue.core import JobQueueCluster

BATCH_SYSTEMS = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster", "lsf": "LSFCluster"}
NAMES = ("local", *BATCH_SYSTEMS)
DEFAULT_JOBS = {"minimum-jobs": 0, "maximum-jobs": 1}  # when neither the options nor the profile say
MAX_JOBS = 10_000  # of one cluster (also the bound of sweep --min-jobs and --max-jobs)


@dataclass(frozen=True)
class NamedCluster:
    """A cluster by name; for a batch system, the bounds of its adaptive scaling, in jobs."""

    name: str
    min_jobs: int = 0
    max_jobs: int = 0

    @property
    def section(self) -> str:
        """Its section of Dask's configuration."""
        return f"jobqueue.{self.name}"


def named_cluster(name: str, min_jobs: int | None = None, max_jobs: int | None = None) -> NamedCluster:
    """``--cluster NAME`` checked before anything starts; a batch system's bounds from
    ``--min-jobs``/``--max-jobs``, else from its profile's ``minimum-jobs`` and
    ``maximum-jobs`` (loopcraft's keys in ``jobqueue.NAME``), else `DEFAULT_JOBS`."""
    key = name.strip().lower()
    if key not in NAMES:
        raise SessionError(f"--cluster {name!r}: one of {', '.join(NAMES)} (a batch system's profile: jobqueue.NAME)")
    if key == "local":
        if min_jobs is not None or max_jobs is not None:
            raise SessionError("--min-jobs and --max-jobs are for a batch system's cluster; --workers sizes local")
        return NamedCluster(key)
    import dask_jobqueue  # noqa: F401 - puts dask-jobqueue's defaults (its jobqueue.yaml) in Dask's configuration

    section = NamedCluster(key).section
    low, high = _jobs(section, "minimum-jobs", min_jobs), _jobs(section, "maximum-jobs", max_jobs)
    if not 0 <= low <= high or not 1 <= high <= MAX_JOBS:
        raise SessionError(f"--cluster {key}: {low} to {high} jobs: write 0 <= minimum <= maximum, 1..{MAX_JOBS}")
    return NamedCluster(key, low, high)


def _jobs(section: str, key: str, given: int | None) -> int:
    """A bound given on the command line, else from the profile, else the default."""
    import dask

    if given is not None:
        return given
    value = dask.config.get(f"{section}.{key}", DEFAULT_JOBS[key])
    if isinstance(value, bool) or not isinstance(value, int):
        raise SessionError(f"{section}.{key} in Dask's configuration: {value!r} is not a whole number of jobs")
    return value


def batch_cluster(named: NamedCluster, dashboard: bool = True) -> JobQueueCluster:
    """The batch system's Dask cluster: its scheduler started here, its dashboard where the
    profile says (else on dask-jobqueue's port) or, without ``dashboard``, on a free port;
    no job submitted yet."""
    import dask
    import dask_jobqueue

    kind = getattr(dask_jobqueue, BATCH_SYSTEMS[named.name])
    processes = dask.config.get(f"{named.section}.processes", None) or dask.config.get(f"{named.section}.cores", None)
    prologue = dask.config.get(f"{named.section}.job-script-prologue", None) or []
    scheduler = dask.config.get(f"{named.section}.scheduler-options", None) or {}
    try:
        return kind(
            config_name=named.name,
            scheduler_options=scheduler if dashboard else {**scheduler, "dashboard_address": ":0"},
            job_script_prologue=[*prologue, *quiet_exports()],
            **({"processes": processes} if processes else {}),
        )
    except Exception as exc:  # noqa: BLE001 - a profile that dask-jobqueue refuses, a network it cannot bind
        raise SessionError(
            f"--cluster {named.name}: {reason(exc)} (set it in Dask's configuration, {named.section}.*, "
            "e.g. ~/.config/dask/jobqueue.yaml)"
        ) from None


def quiet_exports() -> list[str]:
    """`QUIET_WORKERS` as the environment variables that set them in a worker's Dask configuration."""
    return [
        "export DASK_" + "__".join(part.upper().replace("-", "_") for part in key.split(".")) + f"={value}"
        for key, value in QUIET_WORKERS.items()
    ]


def job_script(named: NamedCluster) -> str:
    """The job script the cluster would submit for each of its jobs."""
    if named.name not in BATCH_SYSTEMS:
        raise SessionError(f"--print-job-script: a {named.name} cluster has no job script; name a batch system")
    cluster = batch_cluster(named, dashboard=False)
    try:
        return cluster.job_script()
    finally:
        close(None, cluster)


def connect_named(named: NamedCluster, workers: int | None, timeout: float) -> Connection:
    """A client of the named cluster: a local one of ``workers`` processes, or a batch
    system's scaled adaptively between its bounds (planned workers: its maximum)."""
    if named.name not in BATCH_SYSTEMS:
        return connect(None, workers, timeout)
    if workers is not None:
        raise SessionError(f"--workers sizes a local cluster; a {named.name} cluster's size is --max-jobs")
    cluster = batch_cluster(named)
    try:
        adaptive = cluster.adapt(minimum_jobs=named.min_jobs, maximum_jobs=named.max_jobs)
    except Exception as exc:  # noqa: BLE001
        close(None, cluster)
        raise SessionError(f"--cluster {named.name}: cannot scale it: {reason(exc)}") from None
    return Connection(cluster_client(cluster, timeout, f"the {named.name} cluster"), cluster, int(adaptive.maximum))

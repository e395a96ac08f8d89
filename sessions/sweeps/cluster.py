"""Where a sweep's jobs run: a Dask scheduler's address checked before anything
starts, the connect timeout, a local cluster (one quiet, preloaded process per
core), Ctrl-C kept for this process alone, and the tasks' results waited for
with every wait bounded (`InTurn`).  Every failure to start or reach a cluster
is a `SessionError`."""

from __future__ import annotations

import math
import os
import re
import signal
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, NamedTuple
from urllib.parse import urlsplit

from sessions.errors import SessionError, in_words

if TYPE_CHECKING:
    from distributed import Client
    from distributed.deploy import Cluster

DEFAULT_CONNECT_TIMEOUT = 5.0  # s: how long to wait for a scheduler, or for a local cluster's workers


def scheduler_address(text: str | None, label: str = "--scheduler") -> str | None:
    """A scheduler address checked before anything starts: None (a local cluster) or
    tcp://HOST:PORT, HOST a name, an IPv4 address or [IPv6], PORT 1-65535."""
    if text is None:
        return None
    form = f"{label} {text!r}: write tcp://HOST:PORT (PORT 1-65535)"
    if not text.strip():
        raise SessionError(form + f"; leave {label} out for a local cluster")
    parts = urlsplit(text.strip())
    if parts.scheme != "tcp":
        raise SessionError(form + (f"; {parts.scheme}:// is not supported" if parts.scheme else ""))
    try:
        port = parts.port
    except ValueError:
        raise SessionError(form) from None
    host = parts.hostname or ""
    if (
        not port
        or not _HOST.fullmatch(host)
        or parts.username is not None
        or parts.path
        or parts.query
        or parts.fragment
    ):
        raise SessionError(form)
    return f"tcp://{'[' + host + ']' if ':' in host else host}:{port}"


_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9.-]*[A-Za-z0-9])?|[0-9A-Fa-f:.]*:[0-9A-Fa-f:.]*")


def connect_timeout(seconds: float | None) -> float:
    """The connect timeout in seconds (DEFAULT_CONNECT_TIMEOUT for None); positive and finite."""
    value = DEFAULT_CONNECT_TIMEOUT if seconds is None else seconds
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise SessionError(f"--connect-timeout {seconds!r}: a positive number of seconds")
    return float(value)


@contextmanager
def sigint_ignored() -> Iterator[None]:
    """Ctrl-C ignored inside (in the main thread only: elsewhere nothing changes);
    processes started inside inherit it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class Connection(NamedTuple):
    """A client, the cluster started for it (None: a running scheduler's), how many workers
    the cluster is planned to have (0: as many as the scheduler has), and whether those are
    all it will have, there from the start (a local cluster started here: no worker joins
    later to take a chunk left over for it)."""

    client: Client
    cluster: Cluster | None
    workers: int
    fixed: bool = False


def connect(address: str | None, workers: int | None, timeout: float) -> Connection:
    """A client of the scheduler at ``address``, or of a new local cluster; every failure a `SessionError`."""
    from distributed import Client

    if address is not None:
        try:
            return Connection(Client(address, timeout=timeout), None, 0)
        except Exception as exc:  # noqa: BLE001 - whatever answers (or not) there, one clean error
            raise SessionError(
                f"cannot reach the Dask scheduler {address} within {timeout:g} s: {reason(exc)}"
            ) from None
    n = workers or os.cpu_count() or 1
    try:
        with sigint_ignored():  # the worker processes inherit it: Ctrl-C is for this process alone
            cluster = local_cluster(n)
    except Exception as exc:  # noqa: BLE001 - e.g. "Nanny failed to start": one clean error
        raise SessionError(f"cannot start a local Dask cluster of {n} worker(s): {reason(exc)}") from None
    return Connection(cluster_client(cluster, timeout, "the local Dask cluster"), cluster, n, fixed=True)


def cluster_client(cluster: Cluster, timeout: float, label: str) -> Client:
    """A client of a cluster started here; the cluster closed when none can be had."""
    from distributed import Client

    try:
        return Client(cluster, timeout=timeout)
    except Exception as exc:  # noqa: BLE001
        close(None, cluster)
        raise SessionError(f"cannot connect to {label}: {reason(exc)}") from None


# A local cluster's workers run long numerical jobs: Dask's own monitors there only take
# turns at the GIL with them.  Its statistical profiler samples the running job's stack
# every 10 ms: the launch-vehicle sweep's runs took 1.5 times as long as in this process
# (measured in tests/bench, sweep_throughput), about 1.1 times without these.
QUIET_WORKERS = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.gil.enabled": False,
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}
PRELOAD = "sessions.sweeps.worker_preload"  # imports done as the workers start, after any configured preload
# Dask starts its workers with MALLOC_TRIM_THRESHOLD_=65536 (to hand memory back to the system sooner).
# Setting it turns off glibc's adaptive thresholds: every numpy array over 128 KiB is then mapped and
# unmapped anew, and a launch-vehicle run took 1.45 times as long (0.91 against 0.63 s, measured).
# Dask's own value is left out; another one, configured on purpose, is kept.
DASK_DEFAULTS_UNSET = {"MALLOC_TRIM_THRESHOLD_": 65536}


def local_cluster(workers: int):
    """A local Dask cluster of ``workers`` processes of one thread each, quiet (`QUIET_WORKERS`),
    preloaded (`PRELOAD`) and with glibc's own memory thresholds (`DASK_DEFAULTS_UNSET`)."""
    import dask
    from distributed import LocalCluster

    preload = list(dask.config.get("distributed.worker.preload", [])) + [PRELOAD]
    environ = {
        name: value
        for name, value in dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
        if str(DASK_DEFAULTS_UNSET.get(name)) != str(value)
    }
    with dask.config.set(
        {**QUIET_WORKERS, "distributed.worker.preload": preload, "distributed.nanny.pre-spawn-environ": environ}
    ):
        return LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
        )


def reason(exc: BaseException) -> str:
    """An exception in one line of words (`in_words`: dask-jobqueue's put an example on a
    line of its own; no Python type's name)."""
    return in_words(exc)


def close(client, cluster) -> None:
    """Close what was opened; a failure to close never loses the results."""
    for thing in (client, cluster):
        if thing is not None:
            try:
                thing.close()
            except Exception:  # noqa: BLE001, S110 - closing is best effort
                pass


NO_WORKER_WAIT = 60.0  # s: a cluster with no worker this long is given up (a nanny restarts a killed worker in seconds)
# s: no result this long (a worker hung, a scheduler gone), nor STALL_FACTOR times the longest wait between two
# results so far (a sweep of long runs: an optimization may take many minutes), the tasks left are given up
STALL_WAIT = 3600.0
STALL_FACTOR = 10.0
POLL = 1.0  # s: how often a wait looks at the cluster
NOT_COMPUTED = "not computed"  # the status of a task given up (`InTurn`): the reason of each of its runs begins so


class InTurn:
    """Futures handed out as they finish, each with its result (or the exception it raised), as
    `distributed.as_completed` hands them (``update`` adds more), every wait bounded: when the
    cluster has had no worker for `NO_WORKER_WAIT` seconds (every worker killed and none
    restarted: Dask then holds the tasks forever), or no result has come for `STALL_WAIT`
    seconds and `STALL_FACTOR` times the longest wait between two results so far, the
    iteration ends with futures ``left`` and ``given_up`` says why, beginning with
    `NOT_COMPUTED` ("" when every future finished).  A finished task's result is fetched within
    `POLL` seconds or waited for again: a result held by a worker that died is computed anew by
    the scheduler (a plain ``result()`` waits for it, forever when no worker is left)."""

    def __init__(self, client: Client, futures: Iterable) -> None:
        self.client = client
        self.left = set(futures)
        self.bounds = (NO_WORKER_WAIT, STALL_WAIT)
        self.given_up = ""

    def update(self, futures: Iterable) -> None:
        self.left.update(futures)

    def __iter__(self) -> Iterator[tuple[Any, Any]]:
        finished_at, alone_since, longest = time.monotonic(), None, 0.0
        while self.left:
            handed = False
            for future, result in self._finished():
                self.left.discard(future)
                handed = True
                yield future, result
            now = time.monotonic()
            if handed:
                finished_at, alone_since, longest = now, None, max(longest, now - finished_at)
                continue
            alone_since = (alone_since or now) if self._workers() == 0 else None
            if alone_since is not None and now - alone_since >= self.bounds[0]:
                self.given_up = f"{NOT_COMPUTED}: the cluster had no worker for {self.bounds[0]:g} s"
            elif now - finished_at >= (stall := max(self.bounds[1], STALL_FACTOR * longest)):
                self.given_up = f"{NOT_COMPUTED}: no task finished for {stall:.3g} s"
            if self.given_up:
                return

    def _finished(self) -> list[tuple[Any, Any]]:
        """The futures that finished within `POLL` seconds whose results came within `POLL` each."""
        from distributed import wait

        if not any(future.done() for future in self.left):
            try:
                wait(list(self.left), timeout=POLL, return_when="FIRST_COMPLETED")
            except TimeoutError:
                return []
            except Exception:  # noqa: BLE001 - cancelled futures (they are done), or no scheduler to ask
                if not any(future.done() for future in self.left):
                    time.sleep(POLL)
        out = []
        for future in sorted((f for f in self.left if f.done()), key=lambda f: str(f.key)):
            try:
                out.append((future, future.result(timeout=POLL)))
            except TimeoutError:  # its result died with its worker: the scheduler computes it again
                continue
            except Exception as exc:  # noqa: BLE001 - the task's failure, for the caller to record
                out.append((future, exc))
        return out

    def _workers(self) -> int:
        """The workers the scheduler has now (0 when it does not answer)."""
        try:
            return len(self.client.scheduler_info().get("workers", {}))
        except Exception:  # noqa: BLE001 - a scheduler that cannot say has no worker to offer
            return 0

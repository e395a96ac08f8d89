"""Imported by each worker of a local sweep cluster as it starts (Dask's
``distributed.worker.preload``, `sessions.sweeps.jobs.local_cluster`): the job
runner and every installed algorithm (found through its entry point, as the CLI
and the app find it) with what they import (scipy's HiGHS, pydantic's models), so
that a worker's first run does not pay for them.  What those imports leave (about
90 000 objects) is frozen out of the garbage collector's reach (`gc.freeze`): the
first full collection traversed them all, 55-88 ms on each fresh worker in a
study's first tenth of a second (seen at load 2.5), and every later one again."""

import gc

from engine.stepping.registry import registrations
from sessions.sweeps import jobs as sweep_jobs  # noqa: F401 - imported for what it imports
from sessions.sweeps import study_chunks  # noqa: F401 - a tolerance study's chunks, and the batch they run

registrations()
gc.freeze()

"""Tests and benchmarks.  One BLAS thread, as the `loopcraft` command runs
(see tui/__init__.py); set here too because tests import the engine first."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

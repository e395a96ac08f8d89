"""The loopcraft command line and terminal workbench.

The engine's linear algebra is many small problems: OpenBLAS's worker threads
gain nothing there, spin against the UI thread and against sweep processes
(one per core), and made margin timings jump by up to 90 ms.  So the process
uses one BLAS thread unless the environment says otherwise (set before numpy
is first imported)."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

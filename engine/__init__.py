"""The loopcraft engine: numbers only (docs/architecture.md).

Its linear algebra is many small problems, which OpenBLAS's worker threads
do not speed up: they spin against the caller (the bundled OpenBLAS of scipy
1.17 threads even a 4x4 solve), and an slp major iteration took 2.8 s instead
of 0.87 s under load.  So the engine asks for one BLAS thread unless the
environment says otherwise; it takes effect when the engine is imported
before numpy (the command line and the app set it first themselves)."""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

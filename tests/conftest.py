"""Hypothesis runs derandomized in `make test` (the same examples on every
machine, so CI is repeatable); `HYPOTHESIS_PROFILE=explore make test` draws
new examples each run to look for more."""

import os

from hypothesis import settings

settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

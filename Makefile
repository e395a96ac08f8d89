# make run   : set up .venv if needed, install loopcraft, open the app on an example
# make test  : set up .venv with the test extras and run the test suite but its long tier (TEST_WORKERS=2
#              processes): under ten minutes on a quiet two-core machine
# make test-long : the long tier alone: the tests marked long, each over five seconds (Dask clusters,
#              Chromium, Octave, campaigns, long app sequences); .ci/run runs make test, then this
# make test-fast : the unit tests alone (no app, fuzzers, benches or tests marked slow): under a minute
# make lint  : ruff (lint and format check) and mypy on the public seams
# make bench : run the benchmarks, write bench-results.json; fails when a ratio target is missed
#              (BENCH_ARGS='--only margins,analyze --repeat 10' for a quick subset)
# make fuzz  : the session fuzzer on 20 000 mutated examples (make test runs 600)
#              and the app fuzzer on 200 sessions under the pilot (make test runs 3),
#              and 60 random key and mouse sequences a size on the plots (make test runs 2),
#              and slp against brute force on 280 more problems (make test runs the twenty of tests/engine),
#              and the polished gain loci of 80 more random loops (make test runs 21),
#              and 2000 command cases (set, tune, export and report onto every kind of target,
#              discretized blocks, state-space plants; make test runs 30)
# the distribution's CPython when it is 3.11 or later: built with profile-guided and link-time
# optimization, it runs the suite in about 20 % less time than an unoptimized build (pyenv's
# default); any other python3 otherwise
PYTHON ?= $(shell /usr/bin/python3 -c 'import sys, venv, ensurepip; sys.exit(sys.version_info < (3, 11))' 2>/dev/null \
	&& echo /usr/bin/python3 || echo python3)
# pytest-xdist processes for make test (the suite mostly waits on apps to settle: two halve its time)
TEST_WORKERS ?= 2
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)
# the tests' plug-in algorithms (tests/plugins), installed beside loopcraft as a plug-in would be (tests only)
PLUGINS := $(VENV)/.plugins-$(shell cat tests/plugins/pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: run test test-long test-fast lint bench fuzz clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

$(PLUGINS): tests/plugins/pyproject.toml $(STAMP)
	$(BIN)/python -m pip install --quiet --no-deps -e tests/plugins
	rm -f $(VENV)/.plugins-*
	touch $(PLUGINS)

run: $(STAMP)
	$(BIN)/loopcraft $(if $(ARGS),$(ARGS),--example cip_launch_vehicle)

test: $(PLUGINS)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) -m "not long" $(PYTEST_ARGS)

test-long: $(PLUGINS)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) -m long $(PYTEST_ARGS)

test-fast: $(PLUGINS)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) -m "not slow and not long and not app and not fuzz and not bench" $(PYTEST_ARGS)

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

fuzz: $(PLUGINS)
	LOOPCRAFT_FUZZ_CASES=$${LOOPCRAFT_FUZZ_CASES:-20000} LOOPCRAFT_FUZZ_APP_CASES=$${LOOPCRAFT_FUZZ_APP_CASES:-200} \
		LOOPCRAFT_FUZZ_PLOT_CASES=$${LOOPCRAFT_FUZZ_PLOT_CASES:-60} \
		LOOPCRAFT_FUZZ_BRUTE_FORCE_CASES=$${LOOPCRAFT_FUZZ_BRUTE_FORCE_CASES:-280} \
		LOOPCRAFT_FUZZ_COMMAND_CASES=$${LOOPCRAFT_FUZZ_COMMAND_CASES:-2000} \
		LOOPCRAFT_FUZZ_LOCUS_CASES=$${LOOPCRAFT_FUZZ_LOCUS_CASES:-80} \
		LOOPCRAFT_FUZZ_MANY_POLE_CASES=$${LOOPCRAFT_FUZZ_MANY_POLE_CASES:-30} \
		$(BIN)/python -m pytest -q tests/fuzz $(PYTEST_ARGS)

bench: $(STAMP)
	$(BIN)/python -m tests.bench.run --out bench-results.json $(BENCH_ARGS)

clean:
	rm -rf $(VENV) bench-results.json .pytest_cache

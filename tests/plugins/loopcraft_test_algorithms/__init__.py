"""Two algorithms that are not loopcraft's, installed beside it as a plug-in would be
(`pip install -e tests/plugins`, run by `make test`'s set-up): each is found only
through its entry point in tests/plugins/pyproject.toml, by the CLI, the workbench
and the sweeps' Dask workers alike."""

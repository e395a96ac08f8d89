"""Sweeps on Dask: planning, the jobs and their batches, the cluster, the
results."""

"""The app's actions that run in workers: the run loop, sweeps, exports and
screenshots."""

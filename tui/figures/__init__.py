"""Figures as data, free of plotext and Textual: every plot's series, limits,
ticks and probe, made from a view; zoom, pan and cursor as plain state."""

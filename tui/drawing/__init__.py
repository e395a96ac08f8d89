"""Drawing figures on a text canvas: the one place that knows the plotting library."""

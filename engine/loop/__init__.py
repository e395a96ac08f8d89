"""A design's loop: open- and closed-loop responses of a network, the fast
evaluator, the pole-zero form, the state-space realization, the cache of
tabulated fits."""

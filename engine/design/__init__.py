"""The design problem: conditions, parameters, targets, linear constraints
between parameters, the measure kinds and the generic tableau."""

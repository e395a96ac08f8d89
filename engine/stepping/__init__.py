"""What every algorithm plugs into: the stepper protocol and registry, typed
JSON fields of its memory, the numerical guard, the presenter."""

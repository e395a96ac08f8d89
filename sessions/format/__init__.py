"""The JSON session format: schema, limits, stable JSON text, atomic save
files, the load-time checks, the constraint lines."""
